#include "src/ros/shard/shard_node.h"

#include <bsf_vpr/ShardInfo.h>

#include <chrono>

#include "bsf_vpr/core/sharding.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/common/service_queue.h"
#include "src/ros/map/set_loading.h"

namespace bsf_vpr {

ShardNode::ShardNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(std::move(nh)), pnh_(std::move(pnh)) {}

ShardNode::~ShardNode() {
  if (load_spinner_) load_spinner_->stop();
}

void ShardNode::Start() {
  params_ = LoadFusionParams(pnh_);
  if (!params_.shards.empty()) {
    throw std::invalid_argument(
        "a fusion shard holds sets; the parameter shards is the "
        "combiner's (a fusion node)");
  }
  // The shard computes distances only: its method is never run (the combiner's decides).
  params_.recognizer.method = "bsf";
  if (!params_.data_directory.empty()) {
    data_dir_ = std::make_unique<DataDirectory>(params_.data_directory, /*create=*/true);
  }
  LoadConfiguredSets(&params_, &sets_);
  sets_.SetOptions(params_.recognizer);
  for (const StoredReferenceSet& s : sets_.map().sets()) fingerprints_.push_back(SetFingerprint(s));
  PrepareFirstStage();

  distances_pub_ = pnh_.advertise<ShardDistances>(names::kShardDistancesTopic,
                                                  static_cast<uint32_t>(params_.queue_size));
  info_pub_ = pnh_.advertise<ShardInfo>(names::kShardInfoTopic, 1, /*latch=*/true);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    PublishInfo();
  }
  services_.push_back(
      pnh_.advertiseService(names::kListReferenceSetsService, &ShardNode::OnList, this));
  services_.push_back(
      pnh_.advertiseService(names::kUnloadReferenceSetService, &ShardNode::OnUnload, this));
  services_.push_back(
      pnh_.advertiseService(names::kShardDistancesService, &ShardNode::OnCompute, this));
  // Its own queue and thread: reading a large set must not hold up the descriptors.
  services_.push_back(AdvertiseOnQueue<LoadReferenceSet>(pnh_, names::kLoadReferenceSetService,
                                                         &ShardNode::OnLoad, this, &load_queue_));
  load_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &load_queue_);
  load_spinner_->start();

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
  diagnostics_->setHardwareID("bsf_vpr");
  diagnostics_->add("shard", this, &ShardNode::Diagnose);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(0.1),
                                       [this](const ros::TimerEvent&) { diagnostics_->update(); });
  last_diagnostics_ = ros::WallTime::now();

  descriptor_sub_ =
      nh_.subscribe(names::kDescriptorTopic, static_cast<uint32_t>(params_.queue_size),
                    &ShardNode::OnDescriptor, this);
  ROS_INFO("bsf_vpr: shard %s ready: %d reference set(s), %s distance", pnh_.getNamespace().c_str(),
           sets_.map().num_sets(), ToString(params_.recognizer.metric).c_str());
}

void ShardNode::PrepareFirstStage() {
  PrepareFirstStageOrFallBack(&sets_, &params_, &first_stage_error_);
}

void ShardNode::PublishInfo() {
  ShardInfo info;
  info.header.stamp = ros::Time::now();
  info.shard = pnh_.getNamespace();
  info.distance = ToString(params_.recognizer.metric);
  const ReferenceMap& map = sets_.map();
  for (int u = 0; u < map.num_sets(); ++u) {
    info.sets.push_back(ToShardSetMsg(map.set(u), fingerprints_.at(static_cast<size_t>(u))));
  }
  info_pub_.publish(info);
}

void ShardNode::ComputeFor(const Descriptor& descriptor, ShardDistances* out) {
  const auto start = std::chrono::steady_clock::now();
  out->header = descriptor.header;
  out->shard = pnh_.getNamespace();
  const ReferenceMap& map = sets_.map();
  if (map.num_sets() > 0) {  // a shard without sets answers with none
    try {
      const std::vector<RowMatrixXf> d = sets_.Distances(DescriptorView(descriptor));
      size_t total = 0;
      for (const RowMatrixXf& m : d) total += static_cast<size_t>(m.size());
      out->distances.reserve(total);
      for (int u = 0; u < map.num_sets(); ++u) {
        const RowMatrixXf& m = d[static_cast<size_t>(u)];
        out->set_names.push_back(map.set(u).name());
        out->fingerprints.push_back(fingerprints_.at(static_cast<size_t>(u)));
        out->counts.push_back(static_cast<int32_t>(m.size()));
        out->distances.insert(out->distances.end(), m.data(), m.data() + m.size());
      }
    } catch (const std::exception& e) {
      out->set_names.clear();
      out->fingerprints.clear();
      out->counts.clear();
      out->distances.clear();
      out->error = e.what();
    }
  }
  out->processing_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void ShardNode::OnDescriptor(const Descriptor::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string mismatch = DescriptorTypeMismatch(msg->descriptor_type, sets_.map());
  if (!mismatch.empty()) {
    type_mismatch_ = mismatch;
    ROS_WARN_THROTTLE(5.0, "bsf_vpr: shard %s: %s: the distances compare unlike descriptors",
                      pnh_.getNamespace().c_str(), mismatch.c_str());
  }
  ShardDistances out;
  ComputeFor(*msg, &out);
  if (out.error.empty()) {
    ++processed_;
    processing_s_sum_ += out.processing_time;
  } else {
    ++rejected_;
    last_rejection_ = out.error;
    ROS_ERROR_THROTTLE(1.0, "bsf_vpr: shard %s refused a descriptor: %s",
                       pnh_.getNamespace().c_str(), out.error.c_str());
  }
  // Published either way: the combiner learns at once that this query cannot be answered.
  distances_pub_.publish(out);
}

bool ShardNode::OnCompute(GetShardDistances::Request& req, GetShardDistances::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  ComputeFor(req.descriptor, &res.distances);
  return true;
}

bool ShardNode::OnList(ListReferenceSets::Request&, ListReferenceSets::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const StoredReferenceSet& s : sets_.map().sets()) {
    res.sets.push_back(ToInfoMsg(s));
    res.sets.back().shard = pnh_.getNamespace();
  }
  res.num_places = sets_.map().num_places();
  return true;
}

bool ShardNode::OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res) {
  try {
    ReferenceSet set = ReadRequestedSet(data_dir_.get(), req);
    std::lock_guard<std::mutex> lock(mutex_);
    TakeSetDistance(set, data_dir_->Relative(req.path), &params_, &sets_);
    const std::string name = set.name;
    const int places = set.size();
    sets_.AddReferenceSet(std::move(set));
    fingerprints_.push_back(SetFingerprint(sets_.map().sets().back()));
    PrepareFirstStage();
    PublishInfo();
    res.success = true;
    res.message = "loaded '" + name + "' (" + std::to_string(places) + " places) on shard " +
                  pnh_.getNamespace();
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_WARN("bsf_vpr: shard %s: load_reference_set refused: %s", pnh_.getNamespace().c_str(),
             e.what());
  }
  return true;
}

bool ShardNode::OnUnload(UnloadReferenceSet::Request& req, UnloadReferenceSet::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    const int u = sets_.map().IndexOf(req.name);
    if (u < 0) {
      throw std::invalid_argument("no reference set named " + QuotedForMessage(req.name) +
                                  " is loaded on shard " + pnh_.getNamespace());
    }
    sets_.RemoveReferenceSet(req.name);
    fingerprints_.erase(fingerprints_.begin() + u);
    PrepareFirstStage();
    PublishInfo();
    res.success = true;
    res.message = "unloaded '" + req.name + "' from shard " + pnh_.getNamespace();
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

void ShardNode::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double elapsed = std::max(1e-9, (now - last_diagnostics_).toSec());
  const ReferenceMap& map = sets_.map();
  if (rejected_ > 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "refused %d descriptor(s): %s",
                    rejected_, last_rejection_.c_str());
  } else if (!first_stage_error_.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "first stage pca failed, exact search instead: " + first_stage_error_);
  } else if (!type_mismatch_.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, type_mismatch_);
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "computing distances");
  }
  status.add("input rate (Hz)", processed_ / elapsed);
  status.add("mean processing time (ms)", processed_ ? 1e3 * processing_s_sum_ / processed_ : 0.0);
  status.add("refused descriptors", rejected_);
  status.add("distance", ToString(params_.recognizer.metric));
  status.add("first stage", first_stage_error_.empty()
                                ? sets_.distance_stage().Summary()
                                : "exact: pca failed: " + first_stage_error_);
  status.add("loaded reference sets", map.num_sets());
  for (const StoredReferenceSet& s : map.sets()) {
    status.addf("set: " + s.name(), "%d places, %.1f MB", s.size(), s.MemoryBytes() / 1e6);
  }
  processed_ = rejected_ = 0;
  processing_s_sum_ = 0;
  type_mismatch_.clear();
  last_diagnostics_ = now;
}

}  // namespace bsf_vpr
