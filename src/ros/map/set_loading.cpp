#include "src/ros/map/set_loading.h"

#include <ros/console.h>
#include <ros/package.h>
#include <ros/wall_timer.h>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"

namespace bsf_vpr {

namespace {

void CheckSetDistance(const ReferenceSet& set, DistanceMetric metric, const std::string& where) {
  const std::string name = ToString(metric);
  if (!set.distance.empty() && set.distance != name) {
    throw std::invalid_argument("reference set '" + set.name + "' (" + where + ") is meant for " +
                                set.distance + " distance, the node uses " + name);
  }
}

}  // namespace

std::string ResolveConfiguredPath(const std::string& base, const std::string& path) {
  constexpr char kScheme[] = "package://";
  if (path.rfind(kScheme, 0) != 0) return ResolvePath(base, path);
  const std::string rest = path.substr(sizeof(kScheme) - 1);
  const size_t slash = rest.find('/');
  const std::string package = rest.substr(0, slash);
  const std::string folder = package.empty() ? "" : ros::package::getPath(package);
  if (folder.empty()) {
    throw std::invalid_argument("reference set path " + QuotedForMessage(path) + " names package " +
                                QuotedForMessage(package) +
                                ", which ROS does not find (ROS_PACKAGE_PATH)");
  }
  return slash == std::string::npos ? folder : folder + rest.substr(slash);
}

void LoadConfiguredSets(FusionParams* params, PlaceRecognizer* recognizer) {
  const std::string base = params->data_directory.empty() ? "." : params->data_directory;
  std::vector<std::pair<ReferenceSet, std::string>> sets;  // and the file each came from
  for (const ReferenceSetEntry& e : params->reference_sets) {
    const std::string path = ResolveConfiguredPath(base, e.path);
    ReferenceSet set = LoadReferenceSetFile(path, e.name);
    if (!e.condition.empty()) set.condition = e.condition;
    sets.emplace_back(std::move(set), path);
  }
  if (!params->distance_given()) {
    // The distance the sets were made for, if they agree on one.
    std::string declared;
    for (const auto& [set, path] : sets) {
      if (set.distance.empty()) continue;
      if (!declared.empty() && set.distance != declared) {
        throw std::invalid_argument("the reference sets are meant for different distances (" +
                                    declared + " and " + set.distance + " for '" + set.name +
                                    "'); set the parameter distance");
      }
      declared = set.distance;
    }
    if (!declared.empty()) params->recognizer.metric = ParseDistanceMetric(declared);
  }
  recognizer->SetStoragePrecision(params->storage);
  recognizer->SetPlacePoseTolerance(params->place_pose_tolerance_m);
  for (auto& entry : sets) {
    CheckSetDistance(entry.first, params->recognizer.metric, entry.second);
    recognizer->AddReferenceSet(std::move(entry.first));
    const StoredReferenceSet& s = recognizer->map().sets().back();
    ROS_INFO("bsf_vpr: loaded reference set '%s' (%d places, dimension %d, %s)", s.name().c_str(),
             s.size(), s.dimension(), ToString(s.precision()).c_str());
  }
}

ReferenceSet ReadRequestedSet(const DataDirectory* dir, const LoadReferenceSet::Request& req) {
  if (!dir) {
    throw std::invalid_argument("no data directory is configured (parameter data_directory)");
  }
  ReferenceSet set = LoadReferenceSetFile(*dir, req.path, req.name);
  if (!req.condition.empty()) set.condition = req.condition;
  return set;
}

void TakeSetDistance(const ReferenceSet& set, const std::string& where, FusionParams* params,
                     PlaceRecognizer* recognizer) {
  if (!params->distance_given() && recognizer->map().num_sets() == 0 && !set.distance.empty()) {
    // No distance configured and nothing loaded yet: the first set's own distance.
    RecognizerOptions o = recognizer->options();
    o.metric = ParseDistanceMetric(set.distance);
    recognizer->SetOptions(o);
    params->recognizer.metric = o.metric;
    ROS_INFO("bsf_vpr: distance %s, as the reference set '%s' declares", set.distance.c_str(),
             set.name.c_str());
  }
  CheckSetDistance(set, params->recognizer.metric, where);
}

std::string DescriptorTypeMismatch(const std::string& type, const ReferenceMap& map) {
  if (type.empty()) return "";
  for (const StoredReferenceSet& s : map.sets()) {
    if (!s.descriptor_type().empty() && s.descriptor_type() != type) {
      return "descriptors of type " + QuotedForMessage(type, 60) + " meet set '" + s.name() +
             "' of type '" + s.descriptor_type() + "'";
    }
  }
  return "";
}

// Below this share of the rows' energy the first stage's basis warns (docs/performance.md).
constexpr double kFirstStageEnergyWarning = 0.99;

void PrepareFirstStageOrFallBack(PlaceRecognizer* recognizer, FusionParams* params,
                                 std::string* error) {
  if (recognizer->distance_stage().kind() == FirstStageKind::kExact ||
      recognizer->map().num_sets() == 0) {
    return;
  }
  const ros::WallTime start = ros::WallTime::now();
  try {
    recognizer->PrepareFirstStage();
  } catch (const std::exception& e) {
    // The sets stay as they are; exact search answers until the node is restarted, rather
    // than every descriptor trying the build again.
    RecognizerOptions exact = recognizer->options();
    exact.first_stage.kind = ToString(FirstStageKind::kExact);
    recognizer->SetOptions(exact);
    params->recognizer.first_stage.kind = exact.first_stage.kind;
    *error = e.what();
    ROS_ERROR("bsf_vpr: the pca first stage could not be built (%s): exact search from now on",
              e.what());
    return;
  }
  ROS_INFO("bsf_vpr: first stage %s, built in %.2f s",
           recognizer->distance_stage().Summary().c_str(), (ros::WallTime::now() - start).toSec());
  const double energy = recognizer->distance_stage().index()->RetainedEnergy();
  if (energy < kFirstStageEnergyWarning) {
    // On the real data, bases keeping under 99% lost 2 points of R@1 and more.
    ROS_WARN(
        "bsf_vpr: the first stage's basis keeps only %.1f%% of the rows' energy: recall "
        "may fall short of exact search; raise first_stage_dimensions or "
        "first_stage_sample_rows, or measure with bsf_evaluate --first-stage pca "
        "(docs/performance.md, large maps)",
        100.0 * energy);
  }
}

}  // namespace bsf_vpr
