#include "src/ros/shard/shard_node.h"

#include <bsf_vpr/ShardInfo.h>

#include <chrono>

#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/common/service_queue.h"
#include "src/ros/map/make_map.h"

namespace bsf_vpr {

ShardNode::ShardNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(std::move(nh)), pnh_(std::move(pnh)) {}

ShardNode::~ShardNode() {
  if (load_spinner_) load_spinner_->stop();
}

void ShardNode::Start() {
  params_ = LoadShardParams(pnh_);
  if (!params_.data_directory.empty()) {
    data_dir_ = std::make_unique<DataDirectory>(params_.data_directory, /*create=*/true);
  }
  LocalMapOptions options = ToLocalMapOptions(params_, params_.first_stage);
  options.fingerprints = true;  // the combiner tells its sets' versions apart by them
  map_ = std::make_unique<LocalMap>(options, data_dir_.get(), pnh_.getNamespace());
  map_->SetJoint(ToJointKind(params_.fusion_joint), params_.joint);  // built in the background
  map_->LoadConfigured(ResolveConfiguredSets(params_));

  distances_pub_ = pnh_.advertise<ShardDistances>(names::kShardDistancesTopic,
                                                  static_cast<uint32_t>(params_.queue_size));
  info_pub_ = pnh_.advertise<ShardInfo>(names::kShardInfoTopic, 1, /*latch=*/true);
  services_.push_back(
      pnh_.advertiseService(names::kShardInfoService, &ShardNode::OnInfo, this));
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
  {
    // After the services: a combiner confirms it with get_shard_info.
    MutexLock lock(&mutex_);
    PublishInfo();
  }

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
  diagnostics_->setHardwareID("bsf_vpr");
  diagnostics_->add("shard", this, &ShardNode::Diagnose);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(0.1),
                                       [this](const ros::TimerEvent&) { diagnostics_->update(); });
  {
    MutexLock lock(&mutex_);
    last_diagnostics_ = ros::WallTime::now();
  }

  descriptor_sub_ =
      nh_.subscribe(names::kDescriptorTopic, static_cast<uint32_t>(params_.queue_size),
                    &ShardNode::OnDescriptor, this);
  ROS_INFO("bsf_vpr: shard %s ready: %d reference set(s), %s distance", pnh_.getNamespace().c_str(),
           map_->num_sets(), ToString(map_->metric()).c_str());
}

ShardInfo ShardNode::Info() const {
  ShardInfo info;
  info.header.stamp = ros::Time::now();
  info.shard = pnh_.getNamespace();
  info.distance = ToString(map_->metric());
  map_->ForEachSet([&info](const StoredReferenceSet& set, uint64_t fingerprint) {
    info.sets.push_back(ToShardSetMsg(set, fingerprint));
  });
  return info;
}

void ShardNode::PublishInfo() {
  published_generation_ = map_->layout()->generation;
  info_pub_.publish(Info());
}

bool ShardNode::OnInfo(GetShardInfo::Request&, GetShardInfo::Response& res) {
  MutexLock lock(&mutex_);
  res.node = ros::this_node::getName();
  res.info = Info();
  return true;
}

void ShardNode::OnDescriptor(const Descriptor::ConstPtr& msg) {
  MutexLock lock(&mutex_);
  const std::string mismatch = map_->DescriptorTypeMismatch(msg->descriptor_type);
  if (!mismatch.empty()) {
    type_mismatch_ = mismatch;
    ROS_WARN_THROTTLE(5.0, "bsf_vpr: shard %s: %s: the distances compare unlike descriptors",
                      pnh_.getNamespace().c_str(), mismatch.c_str());
  }
  const ShardDistances out = Answer(*msg);
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
  if (map_->layout()->generation != published_generation_) PublishInfo();  // a set dropped
}

ShardDistances ShardNode::Answer(const Descriptor& descriptor) const {
  const auto start = std::chrono::steady_clock::now();
  ShardDistances out;
  out.header = descriptor.header;
  out.shard = pnh_.getNamespace();
  ToShardDistancesMsg(map_->Answer(ToQueryDescriptor(descriptor)), &out);
  out.processing_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

bool ShardNode::OnCompute(GetShardDistances::Request& req, GetShardDistances::Response& res) {
  res.distances = Answer(req.descriptor);
  return true;
}

bool ShardNode::OnList(ListReferenceSets::Request&, ListReferenceSets::Response& res) {
  ToListResponse(map_->List(), &res);
  for (ReferenceSetInfo& info : res.sets) info.shard = pnh_.getNamespace();
  return true;
}

template <typename Response>
void ShardNode::Change(const std::string& service, const std::function<std::string()>& change,
                       Response* res) {
  try {
    res->message = change();
    res->success = true;
    MutexLock lock(&mutex_);
    PublishInfo();  // the combiner takes the new sets from it
    ROS_INFO("bsf_vpr: %s", res->message.c_str());
  } catch (const std::exception& e) {
    res->success = false;
    res->message = e.what();
    ROS_WARN("bsf_vpr: shard %s: %s refused: %s", pnh_.getNamespace().c_str(), service.c_str(),
             e.what());
  }
}

bool ShardNode::OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res) {
  Change(
      names::kLoadReferenceSetService, [&] { return map_->Load(ToLoadRequest(req), nullptr); },
      &res);
  return true;
}

bool ShardNode::OnUnload(UnloadReferenceSet::Request& req, UnloadReferenceSet::Response& res) {
  Change(
      names::kUnloadReferenceSetService, [&] { return map_->Unload(req.name); }, &res);
  return true;
}

void ShardNode::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  MutexLock lock(&mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double elapsed = std::max(1e-9, (now - last_diagnostics_).toSec());
  const std::string problem = map_->Problem();
  if (rejected_ > 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "refused %d descriptor(s): %s",
                    rejected_, last_rejection_.c_str());
  } else if (!problem.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problem);
  } else if (!type_mismatch_.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, type_mismatch_);
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "computing distances");
  }
  status.add("input rate (Hz)", processed_ / elapsed);
  status.add("mean processing time (ms)", processed_ ? 1e3 * processing_s_sum_ / processed_ : 0.0);
  status.add("refused descriptors", rejected_);
  status.add("distance", ToString(map_->metric()));
  AddStatus(map_->Diagnose(), status);  // the first stage
  // Each set's size and bytes, read in place (List would copy every set's layout).
  int held = 0;
  map_->ForEachSet([&](const StoredReferenceSet& s, uint64_t) {
    ++held;
    status.addf("set: " + s.name(), "%d places, %.1f MB", s.size(), s.MemoryBytes() / 1e6);
  });
  status.add("loaded reference sets", held);
  processed_ = rejected_ = 0;
  processing_s_sum_ = 0;
  type_mismatch_.clear();
  last_diagnostics_ = now;
}

}  // namespace bsf_vpr
