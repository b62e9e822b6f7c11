#include "src/ros/map/local_map.h"

#include <ros/console.h>
#include <ros/wall_timer.h>

#include <chrono>
#include <cstdio>

#include "bsf_vpr/core/sharding.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/ros/common/conversions.h"
#include "src/ros/map/set_loading.h"

namespace bsf_vpr {

namespace {

// Below this share of the rows' energy the first stage's basis warns (docs/performance.md).
constexpr double kFirstStageEnergyWarning = 0.99;

}  // namespace

LocalMapOptions LocalMapOptions::From(const MapParams& params,
                                      const FirstStageOptions& first_stage) {
  LocalMapOptions o;
  o.metric = params.distance;
  o.storage = params.storage;
  o.place_pose_tolerance_m = params.place_pose_tolerance_m;
  o.first_stage = first_stage;
  return o;
}

LocalMap::LocalMap(LocalMapOptions options, const DataDirectory* data_dir, std::string shard)
    : options_(std::move(options)),
      data_dir_(data_dir),
      shard_(std::move(shard)),
      metric_(options_.metric.value_or(DistanceMetric::kEuclidean)),
      layout_(std::make_shared<MapLayout>(PlaceLayout(), 0)) {
  map_.SetStoragePrecision(options_.storage);
  map_.SetPlacePoseTolerance(options_.place_pose_tolerance_m);
  stage_.SetOptions(options_.first_stage);
}

void LocalMap::LoadConfigured(const std::vector<ReferenceSetEntry>& entries,
                              const std::string& base) {
  std::vector<std::pair<ReferenceSet, std::string>> sets;  // and the file each came from
  for (const ReferenceSetEntry& e : entries) {
    const std::string path = ResolveConfiguredPath(base, e.path);
    ReferenceSet set = LoadReferenceSetFile(path, e.name);
    if (!e.condition.empty()) set.condition = e.condition;
    sets.emplace_back(std::move(set), path);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!options_.metric) {
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
    if (!declared.empty()) metric_ = ParseDistanceMetric(declared);
  }
  for (auto& [set, path] : sets) {
    CheckSetDistance(set, metric_, path);
    map_.Add(std::move(set));
    const StoredReferenceSet& s = map_.sets().back();
    if (options_.fingerprints) fingerprints_.push_back(SetFingerprint(s));
    ROS_INFO("bsf_vpr: loaded reference set '%s' (%d places, dimension %d, %s)", s.name().c_str(),
             s.size(), s.dimension(), ToString(s.precision()).c_str());
  }
  Changed();
}

MapBackend::Layout LocalMap::layout() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return layout_;
}

DistanceMetric LocalMap::metric() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return metric_;
}

RowMatrixXf LocalMap::QueryRow(const Descriptor& descriptor) const {
  const Eigen::Map<const Eigen::VectorXf> d = DescriptorView(descriptor);
  map_.CheckQuery(d);
  return d.transpose();
}

MapBackend::Query LocalMap::Ask(const Descriptor& descriptor) {
  const auto start = std::chrono::steady_clock::now();
  Query query;
  query.header = descriptor.header;
  std::lock_guard<std::mutex> lock(mutex_);
  const RowMatrixXf row = QueryRow(descriptor);
  query.layout = layout_;
  query.distances = QueryDistances::AllPresent(stage_.Distances(metric_, row, map_));
  if (joint_ && joint_->num_places() == map_.num_places()) {
    query.distances.SetJoint({joint_->kind(), joint_build_, joint_->Distances(row)});
  }
  query.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return query;
}

std::string LocalMap::Load(const LoadReferenceSet::Request& request, const SetCheck& check) {
  if (!request.shard.empty()) {
    throw std::invalid_argument("shard " + QuotedForMessage(request.shard) +
                                " given, but this node fuses no shards (parameter shards)");
  }
  ReferenceSet set = ReadRequestedSet(data_dir_, request);  // without the lock
  if (check) check(set.name);
  std::lock_guard<std::mutex> lock(mutex_);
  return AddLocked(std::move(set), data_dir_->Relative(request.path));
}

std::string LocalMap::Add(ReferenceSet set, const std::string& where) {
  std::lock_guard<std::mutex> lock(mutex_);
  return AddLocked(std::move(set), where);
}

std::string LocalMap::AddLocked(ReferenceSet set, const std::string& where) {
  DistanceMetric metric = metric_;
  if (!options_.metric && map_.num_sets() == 0 && !set.distance.empty()) {
    // No distance configured and nothing loaded yet: the first set's own distance.
    metric = ParseDistanceMetric(set.distance);
  }
  CheckSetDistance(set, metric, where);
  const std::string name = set.name;
  const int places = set.size();
  const std::string declared = set.distance;
  fingerprints_.reserve(fingerprints_.size() + 1);  // no throw once the set is in
  map_.Add(std::move(set));
  if (options_.fingerprints) fingerprints_.push_back(SetFingerprint(map_.sets().back()));
  if (metric != metric_) {
    metric_ = metric;
    ROS_INFO("bsf_vpr: distance %s, as the reference set '%s' declares", declared.c_str(),
             name.c_str());
  }
  Changed();
  return "loaded '" + name + "' (" + std::to_string(places) + " places)" +
         (shard_.empty() ? "" : " on shard " + shard_);
}

std::string LocalMap::Unload(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int u = map_.IndexOf(name);
  if (u < 0) {
    throw std::invalid_argument("no reference set named " + QuotedForMessage(name) + " is loaded" +
                                (shard_.empty() ? "" : " on shard " + shard_));
  }
  map_.Remove(name);
  if (options_.fingerprints) fingerprints_.erase(fingerprints_.begin() + u);
  Changed();
  return "unloaded '" + name + "'" + (shard_.empty() ? "" : " from shard " + shard_);
}

void LocalMap::Changed() {
  layout_ = std::make_shared<MapLayout>(map_.layout(), ++generations_);
  RequestJoint();
  stage_.Invalidate();
  if (stage_.kind() == FirstStageKind::kExact || map_.num_sets() == 0) return;
  const ros::WallTime start = ros::WallTime::now();
  try {
    stage_.Prepare(map_);
  } catch (const std::exception& e) {
    // The sets stay as they are; exact search answers until the node is restarted, rather
    // than every descriptor trying the build again.
    FirstStageOptions exact = stage_.options();
    exact.kind = ToString(FirstStageKind::kExact);
    stage_.SetOptions(exact);
    first_stage_error_ = e.what();
    ROS_ERROR("bsf_vpr: the pca first stage could not be built (%s): exact search from now on",
              e.what());
    return;
  }
  ROS_INFO("bsf_vpr: first stage %s, built in %.2f s", stage_.Summary().c_str(),
           (ros::WallTime::now() - start).toSec());
  const double energy = stage_.index()->RetainedEnergy();
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

void LocalMap::SetJoint(std::optional<JointKind> kind, const JointOptions& options) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool same = kind == joint_kind_ &&
                    options.discriminant_dimensions == joint_options_.discriminant_dimensions &&
                    options.discriminant_ridge == joint_options_.discriminant_ridge;
  if (same) return;
  joint_kind_ = kind;
  joint_options_ = options;
  joint_.reset();  // another kind or other options: the old one answers for nothing asked
  RequestJoint();
}

void LocalMap::RequestJoint() {
  if (joint_ && joint_->num_places() != map_.num_places()) joint_.reset();
  if (!joint_kind_) {
    joint_.reset();
    joint_status_ = "none asked for";
    return;
  }
  std::vector<const StoredReferenceSet*> sets;
  for (const StoredReferenceSet& s : map_.sets()) sets.push_back(&s);
  try {
    CheckJointSets(sets, map_.num_places());
  } catch (const std::invalid_argument& e) {
    joint_.reset();
    joint_status_ = std::string("none: ") + e.what();
    return;
  }
  joint_status_ = "building " + ToString(*joint_kind_) + " of " + std::to_string(map_.num_sets()) +
                  " sets" + (joint_ ? " (the previous one answers meanwhile)" : "");
  joint_builder_.Request(*joint_kind_, map_.sets(), map_.num_places(), joint_options_,
                         layout_->generation);
}

void LocalMap::JointBuilt(JointBuilder::Result result) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (result.generation != layout_->generation || !joint_kind_ || result.kind != *joint_kind_) {
    return;  // the sets or the kind changed since: a newer request is on its way
  }
  char took[32];
  std::snprintf(took, sizeof took, "%.2f s", result.seconds);
  if (!result.joint) {
    joint_.reset();
    joint_status_ = "failed: " + result.error;
    ROS_ERROR(
        "bsf_vpr: the %s representation of the sets could not be built (%s): the method "
        "goes on with the sets alone",
        ToString(result.kind).c_str(), result.error.c_str());
    return;
  }
  joint_ = std::move(result.joint);
  joint_build_ = ++joint_builds_;
  std::string sets;
  for (const std::string& n : joint_->set_names()) sets += (sets.empty() ? "" : ", ") + n;
  joint_status_ = ToString(joint_->kind()) + " of " + sets +
                  (joint_->kind() == JointKind::kDiscriminant
                       ? " (" + std::to_string(joint_->discriminant_dimensions()) + " dimensions)"
                       : std::string()) +
                  ", built in " + took;
  ROS_INFO("bsf_vpr: joint representation %s", joint_status_.c_str());
}

void LocalMap::List(ListReferenceSets::Response* response) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const StoredReferenceSet& s : map_.sets()) response->sets.push_back(ToInfoMsg(s));
  response->num_places = map_.num_places();
}

std::string LocalMap::DescriptorTypeMismatch(const std::string& type) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return TypeMismatch(type, map_.layout());
}

std::string LocalMap::Problem() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return first_stage_error_.empty()
             ? ""
             : "first stage pca failed, exact search instead: " + first_stage_error_;
}

void LocalMap::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  std::lock_guard<std::mutex> lock(mutex_);
  status.add("joint representation", joint_status_);
  status.add("first stage", first_stage_error_.empty()
                                ? stage_.Summary()
                                : "exact: pca failed: " + first_stage_error_);
}

void LocalMap::ShardAnswer(const Descriptor& descriptor, ShardDistances* out) {
  const auto start = std::chrono::steady_clock::now();
  out->header = descriptor.header;
  std::lock_guard<std::mutex> lock(mutex_);
  if (map_.num_sets() > 0) {  // a shard without sets answers with none
    try {
      const RowMatrixXf row = QueryRow(descriptor);
      const std::vector<RowMatrixXf> all = stage_.Distances(metric_, row, map_);
      size_t total = 0;
      for (const RowMatrixXf& m : all) total += static_cast<size_t>(m.size());
      out->distances.reserve(total);
      for (int u = 0; u < map_.num_sets(); ++u) {
        const RowMatrixXf& m = all[static_cast<size_t>(u)];
        out->set_names.push_back(map_.set(u).name());
        out->fingerprints.push_back(fingerprints_.at(static_cast<size_t>(u)));
        out->counts.push_back(static_cast<int32_t>(m.size()));
        out->distances.insert(out->distances.end(), m.data(), m.data() + m.size());
      }
      if (joint_ && joint_->num_places() == map_.num_places()) {
        const RowMatrixXf j = joint_->Distances(row);
        out->joint_kind = ToString(joint_->kind());
        out->joint_build = joint_build_;
        out->joint_sets = joint_->set_names();
        out->joint_distances.assign(j.data(), j.data() + j.size());
      }
    } catch (const std::exception& e) {
      out->set_names.clear();
      out->fingerprints.clear();
      out->counts.clear();
      out->distances.clear();
      out->joint_kind.clear();
      out->joint_sets.clear();
      out->joint_distances.clear();
      out->error = e.what();
    }
  }
  out->processing_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<ShardSet> LocalMap::ShardSets() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<ShardSet> out;
  for (int u = 0; u < map_.num_sets(); ++u) {
    out.push_back(ToShardSetMsg(map_.set(u), fingerprints_.at(static_cast<size_t>(u))));
  }
  return out;
}

int LocalMap::num_sets() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return map_.num_sets();
}

}  // namespace bsf_vpr
