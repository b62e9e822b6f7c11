// bsf_import: a dataset as downloaded (Oxford RobotCar, Nordland, or images/descriptors with
// a pose CSV) to reference sets on one shared place index and query bags (see --help and
// docs/import.md).
//
// Everything is read and checked first, the reference sets are described in memory, the
// bags are written under temporary names; only then are the sets saved and the bags renamed
// into place, so that bad input leaves nothing behind.
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "bsf_vpr/io/reference_set_io.h"
#include "src/tools/common/cli_util.h"
#include "src/tools/common/query_bag.h"
#include "src/tools/import/import_args.h"
#include "src/tools/import/import_outputs.h"
#include "src/tools/import/import_places.h"
#include "src/tools/import/import_traversal.h"

namespace bsf_vpr {
namespace tools {
namespace {

namespace fs = std::filesystem;

// Reads every traversal, references first; errors name the traversal.
std::vector<Traversal> ReadAll(const ImportArgs& a) {
  ReadOptions read;
  read.camera = a.options.camera;
  read.frame_rate_hz = a.options.frame_rate_hz;
  std::vector<Traversal> all;
  const auto read_one = [&](const NamedSpec& s, const char* kind) {
    try {
      all.push_back(ReadTraversal(a.layout, s.name, s.spec, read));
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string(kind) + " '" + s.name + "': " + e.what());
    }
    const Traversal& t = all.back();
    if (t.frames.empty()) {
      throw std::runtime_error(std::string(kind) + " '" + s.name + "' has no frame with a pose (" +
                               std::to_string(t.without_pose) + " frames outside the pose log" +
                               (t.not_downloaded > 0 ? ", " + std::to_string(t.not_downloaded) +
                                                           " timestamps without an image)"
                                                     : ")"));
    }
  };
  for (const NamedSpec& s : a.references) read_one(s, "reference");
  for (const NamedSpec& s : a.queries) read_one(s, "query");
  return all;
}

// Images and descriptor .npy files do not mix, and image options need images.
void CheckInputKinds(const ImportArgs& a, const std::vector<Traversal>& all) {
  const bool npy = all.front().descriptors.size() > 0;
  for (const Traversal& t : all) {
    if ((t.descriptors.size() > 0) != npy) {
      throw std::invalid_argument("traversal '" + t.name + "' and '" + all.front().name +
                                  "': one import takes images or descriptor .npy files, not both");
    }
    if (npy && t.descriptors.cols() != all.front().descriptors.cols()) {
      throw std::invalid_argument("traversal '" + t.name + "' has descriptors of dimension " +
                                  std::to_string(t.descriptors.cols()) + ", '" + all.front().name +
                                  "' " + std::to_string(all.front().descriptors.cols()));
    }
  }
  if (!npy) return;
  if (!a.describer_flag.empty()) {
    throw std::invalid_argument(a.describer_flag +
                                " describes images: descriptor .npy files are "
                                "taken as they are");
  }
  if (!a.resize.empty()) throw std::invalid_argument("--resize goes with images, not .npy files");
}

// Options that only traversals with poses use, and the one only frame-aligned ones use,
// are refused where they would have no effect.
void CheckOptionsApply(const ImportArgs& a, bool with_poses) {
  if (with_poses && a.Given("tolerance")) {
    throw std::invalid_argument(
        "--tolerance is for traversals without poses (frame k = place k); with poses the "
        "ground truth is --tolerance-m");
  }
  for (const char* name : {"place_spacing_m", "association_radius_m", "max_yaw_difference_deg",
                           "add_new_places", "tolerance_m"}) {
    if (!with_poses && a.Given(name)) {
      throw std::invalid_argument(OptionFlag(name) +
                                  " needs poses: these traversals have none (frame k = place "
                                  "k; the ground truth is --tolerance)");
    }
  }
}

// Removes the output folder on failure if this run created it and it stayed empty.
class OutputFolder {
 public:
  explicit OutputFolder(const std::string& dir) : dir_(dir), existed_(fs::exists(dir)) {
    CreateFolders(dir);
  }
  ~OutputFolder() {
    std::error_code ec;
    if (!kept_ && !existed_) fs::remove(dir_, ec);  // only if empty
  }
  void Keep() { kept_ = true; }

 private:
  std::string dir_;
  bool existed_, kept_ = false;
};

std::string PlaceRange(const std::vector<int>& ids) {
  if (ids.empty()) return "none";
  return std::to_string(ids.front()) + ".." + std::to_string(ids.back());
}

void ReportSkipped(const Traversal& t, std::ostream& report) {
  if (t.without_pose > 0) report << "; " << t.without_pose << " frames without a pose skipped";
  if (t.not_downloaded > 0)
    report << "; " << t.not_downloaded << " timestamps without an image (chunk not downloaded)";
}

// The reference sets (the first a.references.size() traversals), described in memory: on
// the place index `index` when the traversals have poses, else frame k = place k
// (*aligned_places: the longest reference).
std::vector<ReferenceSet> MakeReferenceSets(const ImportArgs& a, const std::vector<Traversal>& all,
                                            const FrameDescriber& frames, SharedPlaceIndex* index,
                                            int* aligned_places, std::ostream& report) {
  const bool with_poses = all.front().pose_coordinates != PoseCoordinates::kNone;
  std::vector<ReferenceSet> sets;
  for (size_t r = 0; r < a.references.size(); ++r) {
    const Traversal& t = all[r];
    report << "reference '" << t.name << "': " << t.frames.size() << " frames";
    PlaceAssignment assignment;
    if (with_poses) {
      std::vector<PlacePose> poses;
      for (const Frame& f : t.frames) poses.push_back(f.pose);
      const int before = index->num_places();
      assignment = index->Add(poses);
      if (assignment.place_ids.empty()) {
        throw std::runtime_error("reference '" + t.name + "' passes no place of '" +
                                 all.front().name + "' (within --association-radius-m and " +
                                 "--max-yaw-difference-deg): nothing to describe");
      }
      if (r == 0) {
        // The spacing the places have: the one asked for, unless the frames lie farther
        // apart (a place is then a frame, and the report says so).
        const double asked = a.options.place_index.place_spacing_m;
        const double median = ReferenceSets::MedianSpacing(index->place_poses()).value_or(0.0);
        report << ", " << index->num_places() << " places";
        if (index->num_places() > 1 && median > 1.5 * asked) {
          report << " one every " << median << " m (median): the frames lie farther apart than "
                 << "--place-spacing-m " << asked << ", so each place is a frame";
        } else {
          report << " every " << asked << " m";
        }
        report << " (" << PlaceRange(assignment.place_ids) << ")";
      } else {
        report << ", covers " << assignment.place_ids.size() - assignment.new_places << " of "
               << before << " places";
        if (assignment.new_places > 0) {
          report << ", adds " << assignment.new_places << " (" << before << ".."
                 << index->num_places() - 1 << ")";
        }
      }
    } else {
      for (int k = 0; k < static_cast<int>(t.frames.size()); ++k) {
        assignment.place_ids.push_back(k);
        assignment.frames.push_back(k);
      }
      *aligned_places = std::max(*aligned_places, static_cast<int>(t.frames.size()));
      report << ", frame k = place k";
    }
    ReportSkipped(t, report);
    report << " -> " << (fs::path(a.out_dir) / (t.name + ".yaml")).string() << "\n";
    const auto c = a.conditions.find(t.name);
    sets.push_back(MakeImportedSet(t, assignment, frames, with_poses,
                                   c == a.conditions.end() ? t.name : c->second, a.distance));
  }
  return sets;
}

// The query bags (the traversals after the references), closed under temporary names.
std::vector<std::unique_ptr<QueryBagWriter>> WriteQueryBags(const ImportArgs& a,
                                                            const std::vector<Traversal>& all,
                                                            const FrameDescriber& frames,
                                                            const QueryTruth& truth,
                                                            std::ostream& report) {
  std::vector<std::unique_ptr<QueryBagWriter>> bags;
  for (size_t q = a.references.size(); q < all.size(); ++q) {
    const Traversal& t = all[q];
    const bool as_descriptors = a.options.query_descriptors || t.descriptors.size() > 0;
    bags.push_back(std::make_unique<QueryBagWriter>(
        (fs::path(a.out_dir) / (t.name + ".bag")).string(),
        as_descriptors ? kQueryDescriptorTopic : kQueryImageTopic));
    QueryBagWriter& bag = *bags.back();
    const int n = WriteQueries(t, frames, as_descriptors, truth, a.options.rate_hz, &bag);
    bag.Close();
    report << "query '" << t.name << "': " << n << " frames";
    ReportSkipped(t, report);
    report << " -> " << bag.path() << " (" << bag.query_topic();
    if (truth.by_position != nullptr) {
      report << ", " << kQueryPoseTopic << ", " << kGroundTruthTopic << " within "
             << a.options.tolerance_m << " m)\n";
    } else {
      report << ", " << kGroundTruthTopic << " within " << a.options.tolerance << " places)\n";
    }
  }
  return bags;
}

int Run(int argc, char** argv) {
  const ImportArgs a = ParseImportArgs(argc, argv);
  if (a.help) {
    std::cout << ImportUsage();
    return 0;
  }
  ValidateImageDescriberOptions(a.describer);
  std::vector<Traversal> all = ReadAll(a);
  CheckInputKinds(a, all);
  std::unique_ptr<ImageDescriber> describer;
  if (all.front().descriptors.size() == 0) describer = MakeImageDescriber(a.describer);
  const FrameDescriber frames(describer.get(), a.resize);
  const std::string origin = BringToMapFrame(&all);
  CheckOptionsApply(a, all.front().pose_coordinates != PoseCoordinates::kNone);
  std::ostringstream report;

  SharedPlaceIndex index(a.options.place_index);
  int aligned_places = 0;
  const std::vector<ReferenceSet> sets =
      MakeReferenceSets(a, all, frames, &index, &aligned_places, report);
  const bool with_poses = all.front().pose_coordinates != PoseCoordinates::kNone;
  const PlacesWithinRadius near(index.place_poses(), a.options.tolerance_m);
  QueryTruth truth;
  if (with_poses) {
    truth.by_position = &near;
  } else {
    truth.tolerance = a.options.tolerance;
    truth.num_places = aligned_places;
  }
  OutputFolder out(a.out_dir);
  const std::vector<std::unique_ptr<QueryBagWriter>> bags =
      WriteQueryBags(a, all, frames, truth, report);

  // Everything is made: put it in place.
  for (const ReferenceSet& set : sets) {
    SaveReferenceSet(set, (fs::path(a.out_dir) / (set.name + ".yaml")).string());
  }
  for (const auto& bag : bags) bag->Commit();
  out.Keep();
  if (!origin.empty()) report << "map frame origin: " << origin << "\n";
  std::cout << report.str() << "bsf_import: wrote " << sets.size() << " reference set(s) on "
            << (with_poses ? index.num_places() : aligned_places) << " places and " << bags.size()
            << " query bag(s) to " << a.out_dir << "\n";
  return 0;
}

}  // namespace
}  // namespace tools
}  // namespace bsf_vpr

int main(int argc, char** argv) {
  return bsf_vpr::tools::RunTool("bsf_import", bsf_vpr::tools::Run, argc, argv);
}
