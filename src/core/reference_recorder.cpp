#include "bsf_vpr/core/reference_recorder.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>

namespace bsf_vpr {

const EnumNames<RecordingPlaces>& RecordingPlacesNames() {
  static const EnumNames<RecordingPlaces> kNames{{RecordingPlaces::kSequential, "sequential"},
                                                 {RecordingPlaces::kPose, "pose"},
                                                 {RecordingPlaces::kLocalized, "localized"}};
  return kNames;
}

RecordingPlaces ParseRecordingPlaces(const std::string& name) {
  return RecordingPlacesNames().Parse(name, "places");
}

std::string ToString(RecordingPlaces places) { return RecordingPlacesNames().Name(places); }

void ReferenceRecorder::Start(const std::string& name, const std::string& condition, int dimension,
                              RecordingPlaces places) {
  if (recording_) {
    throw std::invalid_argument("already recording reference set '" + name_ + "'");
  }
  if (name.empty()) throw std::invalid_argument("a recording needs a non-empty name");
  if (dimension < 0) throw std::invalid_argument("dimension must be >= 0");
  recording_ = true;
  places_ = places;
  name_ = name;
  condition_ = condition;
  dimension_ = dimension;
  rows_.clear();
  poses_.clear();
  localized_.clear();
}

void ReferenceRecorder::Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                            const std::optional<PlacePose>& pose,
                            const std::optional<LocalizedPlace>& localized) {
  if (!recording_) throw std::invalid_argument("no recording is running");
  if (places_ == RecordingPlaces::kPose && !pose) {
    throw std::invalid_argument("recording by pose: no pose of the robot for this descriptor");
  }
  if (places_ == RecordingPlaces::kLocalized && (!localized || localized->place < 0)) {
    throw std::invalid_argument("recording by localisation: no accepted place for this descriptor");
  }
  if (descriptor.size() == 0 || (dimension_ != 0 && descriptor.size() != dimension_)) {
    throw std::invalid_argument("recorded descriptor has dimension " +
                                std::to_string(descriptor.size()) + ", expected " +
                                std::to_string(dimension_));
  }
  const std::string problem = QueryDescriptorProblem(descriptor.transpose());
  if (!problem.empty()) throw std::invalid_argument("recorded descriptor " + problem);
  const std::string pose_problem = pose ? PoseProblem(*pose) : "";
  if (!pose_problem.empty()) {
    throw std::invalid_argument("the robot's pose for the recorded descriptor " + pose_problem);
  }
  dimension_ = static_cast<int>(descriptor.size());
  rows_.emplace_back(descriptor);
  poses_.push_back(pose);
  if (places_ == RecordingPlaces::kLocalized) localized_.push_back(*localized);
}

ReferenceSet ReferenceRecorder::Finish(const std::string& descriptor_type, const Map& map) {
  ReferenceSet set = Build(descriptor_type, map);
  Discard();
  return set;
}

ReferenceSet ReferenceRecorder::Build(const std::string& descriptor_type, const Map& map,
                                      std::vector<int>* source_rows) const {
  if (!recording_) throw std::invalid_argument("no recording is running");
  if (rows_.empty()) {
    throw std::invalid_argument("recording '" + name_ + "' received no descriptor");
  }
  RowMatrixXf m(static_cast<Eigen::Index>(rows_.size()), dimension_);
  for (size_t k = 0; k < rows_.size(); ++k) m.row(static_cast<Eigen::Index>(k)) = rows_[k];
  ReferenceSet set;
  std::vector<int> source;
  if (places_ == RecordingPlaces::kPose) {
    set = BuildByPose(std::move(m), map, &source);
  } else if (places_ == RecordingPlaces::kLocalized) {
    set = BuildLocalized(std::move(m), map, &source);
  } else {
    set = MakeReferenceSet(name_, std::move(m), condition_);
    source.resize(rows_.size());
    std::iota(source.begin(), source.end(), 0);
    if (std::all_of(poses_.begin(), poses_.end(), [](const auto& p) { return p.has_value(); })) {
      for (const auto& p : poses_) set.poses.push_back(*p);
    }
  }
  set.name = name_;
  set.condition = condition_;
  set.descriptor_type = descriptor_type;
  if (source_rows) *source_rows = std::move(source);
  return set;
}

namespace {

// The rows of `all` listed in `rows`, in that order.
RowMatrixXf Rows(const RowMatrixXf& all, const std::vector<int>& rows) {
  RowMatrixXf out(static_cast<Eigen::Index>(rows.size()), all.cols());
  for (size_t k = 0; k < rows.size(); ++k) {
    out.row(static_cast<Eigen::Index>(k)) = all.row(rows[k]);
  }
  return out;
}

}  // namespace

ReferenceSet ReferenceRecorder::BuildByPose(RowMatrixXf rows, const Map& map,
                                            std::vector<int>* source) const {
  std::vector<PlacePose> frames;
  for (const auto& p : poses_) frames.push_back(*p);  // Add required every pose
  const bool map_has_poses = std::any_of(map.place_poses.begin(), map.place_poses.end(),
                                         [](const auto& p) { return p.has_value(); });
  // On a map without poses the traversal makes its own places, after the map's.
  const PlaceAssignment a =
      map_has_poses
          ? AssociateWithPlaces(frames, map.place_poses, map.options)
          : MakePlacesAlongRoute(frames, map.options, static_cast<int>(map.place_poses.size()));
  if (a.place_ids.empty()) {
    throw std::invalid_argument(
        "recording '" + name_ + "': none of its " + std::to_string(frames.size()) +
        " descriptors lies within " + std::to_string(map.options.association_radius_m) +
        " m (and the heading tolerance) of a place of the map; is the robot on the mapped "
        "route, in the map's frame? (add_new_places makes new places)");
  }
  ReferenceSet set;
  set.descriptors = Rows(rows, a.frames);
  set.place_ids = a.place_ids;
  set.poses = a.place_poses;
  *source = a.frames;
  return set;
}

ReferenceSet ReferenceRecorder::BuildLocalized(RowMatrixXf rows, const Map& map,
                                               std::vector<int>* source) const {
  // The most confident descriptor of each place, places ascending.
  std::vector<int> best;  // row indices
  std::vector<int> order(localized_.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [this](int a, int b) {
    const LocalizedPlace& x = localized_[static_cast<size_t>(a)];
    const LocalizedPlace& y = localized_[static_cast<size_t>(b)];
    return x.place != y.place ? x.place < y.place : x.confidence > y.confidence;
  });
  ReferenceSet set;
  for (int row : order) {
    const int place = localized_[static_cast<size_t>(row)].place;
    if (!set.place_ids.empty() && set.place_ids.back() == place) continue;
    set.place_ids.push_back(place);
    best.push_back(row);
  }
  set.descriptors = Rows(rows, best);
  *source = best;
  bool all_posed = true;
  for (int place : set.place_ids) {
    const size_t p = static_cast<size_t>(place);
    if (p >= map.place_poses.size() || !map.place_poses[p]) {
      all_posed = false;
      break;
    }
    set.poses.push_back(*map.place_poses[p]);
  }
  if (!all_posed) set.poses.clear();
  return set;
}

void ReferenceRecorder::Discard() {
  recording_ = false;
  rows_.clear();
  poses_.clear();
  localized_.clear();
}

}  // namespace bsf_vpr
