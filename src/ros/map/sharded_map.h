// The map of a fusion node with the parameter `shards` (docs/sharding.md): it holds no
// descriptors. Each fusion shard latches what it holds on ~shard_info and answers every
// descriptor with its distances on ~distances; this map keeps the layout of every shard's
// sets (in the order of `shards`, each shard's sets in its order), joins the answers of one
// query by their stamp (ShardJoin) and hands each query on, with the layout it is for,
// through Callbacks::query. load_reference_set and unload_reference_set are routed to the
// shard concerned and answered once its new shard_info is in the layout.
//
// This map hears the descriptors too (Hear), only to know which stamps are queries: a
// shard's answer for any other stamp is refused (shard_join.h), and an answer whose
// distances no exact distance can be (ShardDistancesProblem: NaN, negative, beyond the
// norms) makes that shard missing for the query. Every call to a shard's service waits a
// bounded time (ShardCall, sharded_map_parts.h): a stalled shard is reported, not waited on.
//
// A shard_info is not believed on its own (ROS 1 cannot authenticate a publisher): the map
// asks the shard's own get_shard_info service (bounded, on a thread of its own) and takes the
// shard's answer. A shard_info whose publisher is not the node the shard's service names is
// refused and counted; one that says other than the shard's answer is counted, and the answer
// taken. A shard that does not answer is asked again every second until it does.
//
// A shard that comes back holding other sets (another fingerprint) changes the layout; a
// shard's sets that cannot share the map with the others' are refused (the layout keeps
// them out) and tried again when another shard's change.
//
// Thread-safe: one lock guards the shards and the join; the callbacks are called without
// it, one at a time, in the order the join released the queries.
#pragma once

#include <bsf_vpr/ShardDistances.h>
#include <bsf_vpr/ShardInfo.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/map/map_backend.h"
#include "bsf_vpr/map/shard_assembly.h"
#include "bsf_vpr/map/shard_join.h"
#include "src/ros/map/map_params.h"

namespace bsf_vpr {

struct ShardedMapOptions {
  // The shards (resolved in the node's namespace) and how long the map waits for them: a
  // query shard_timeout after the first answer, a routed load shard_load_timeout.
  ShardingParams sharding;
  // A call to get_distances, get_shard_info or unload: shard_timeout + shard_call_timeout.
  double call_timeout_s() const { return sharding.shard_timeout + sharding.shard_call_timeout; }
  int queue_size = 1;  // queries pending at most (the node's queue_size)
  // The distance the node is configured with (nullopt: the shards').
  std::optional<DistanceMetric> metric;
  double place_pose_tolerance_m = kDefaultPlacePoseToleranceM;
};

class ShardedMap : public MapBackend {
 public:
  ShardedMap(ros::NodeHandle nh, ShardedMapOptions options);
  ~ShardedMap() override;

  // Subscribes to the shards; queries and layouts are handed on from then on.
  void Start(Callbacks callbacks) override;
  Layout layout() const override;
  DistanceMetric metric() const override;
  // Notes the descriptor's stamp and norm for the join; its query comes back through
  // Callbacks::query once the shards answered.
  std::optional<Query> Hear(const QueryDescriptor& descriptor) override;
  Query Ask(const QueryDescriptor& descriptor) override;
  std::string Load(const LoadRequest& request, const SetCheck& check) override;
  std::string Unload(const std::string& name) override;
  std::string Add(ReferenceSet set, const std::string& where) override;
  std::string CannotRecord() const override;
  SetList List() const override;
  // The shards build the joint representation of their own sets (their parameter
  // fusion_joint) and serve its distances; each query takes, of the kind asked for, the one
  // over every place of the layout built from the most sets (the diagnostics say whose).
  void SetJoint(std::optional<JointKind> kind, const JointOptions& options) override;
  // Nothing is calibrated: the combiner holds no descriptors (List() says so).
  void SetCalibration(std::optional<CalibrationRequest> request) override;
  void WaitForJoint() const override {}
  std::string Problem() const override;
  StatusValues Diagnose() const override;

 private:
  struct Shard {
    std::string name;
    ros::Subscriber info_sub, distances_sub;
    ShardInfo::ConstPtr info;  // the last taken; null before the first
    std::shared_ptr<const ShardSets> sets;  // what `info` says it holds
    uint64_t info_count = 0;
    // A shard_info waiting for the shard's service to confirm it (its call failed), and its
    // publisher; asked again every second.
    ShardInfo::ConstPtr unconfirmed;
    std::string unconfirmed_publisher;
    uint64_t foreign_infos = 0;    // shard_info from a publisher that is not the shard: refused
    uint64_t corrected_infos = 0;  // shard_info other than the shard's answer: the answer taken
    std::string last_foreign;      // who published the last refused one
    std::string refused;               // why its last shard_info was refused ("" if taken)
    ShardInfo::ConstPtr refused_info;  // that shard_info, tried again when the map changes
    uint64_t refusals = 0;
    bool change_expected = false;  // a load or unload was routed to it
    std::string lost;              // sets its last change dropped without one
    // Answers refused for their distances (ShardDistancesProblem), and the last reason.
    int64_t invalid_answers = 0;
    std::string invalid;
    // Calls to its services that outlasted their wait and have not returned yet: while
    // any has not, it is not called again (shared with the calls' threads).
    std::shared_ptr<std::atomic<int>> stalled_calls = std::make_shared<std::atomic<int>>(0);
  };
  using Join = ShardJoin<ShardDistances::ConstPtr>;
  // What the callbacks are to be told, in order: a query, a rejection or a layout.
  struct Outgoing {
    std::optional<Query> query;
    std::string rejection;
    Layout layout;
  };

  void OnInfo(int k, const ros::MessageEvent<const ShardInfo>& event) EXCLUDES(mutex_);
  // Asks shard k's get_shard_info about `msg` (published by `publisher`) and takes what the
  // shard answers; keeps `msg` to ask again when the shard does not answer. Without mutex_,
  // on the info thread.
  void ConfirmInfo(int k, const ShardInfo::ConstPtr& msg, const std::string& publisher)
      EXCLUDES(mutex_);
  // OnInfo's work under mutex_ (a new layout is queued for the callbacks).
  void TakeShardInfo(int k, const ShardInfo::ConstPtr& msg) EXCLUDES(mutex_);
  void OnDistances(int k, const ShardDistances::ConstPtr& msg) EXCLUDES(mutex_);
  // Makes `msg` shard k's layout if it fits the others'; else keeps it as refused. Caller
  // holds mutex_.
  bool TakeInfo(int k, const ShardInfo::ConstPtr& msg) REQUIRES(mutex_);
  // Every shard's sets with shard k's `sets`, in the map's order, and their distance
  // (MergeShardLayouts). Throws std::invalid_argument when they cannot share a map.
  MergedLayout LayoutWith(int k, const ShardSets& sets) const REQUIRES(mutex_);
  // The query of `answers` (one per shard, null where none) on the layout now, for a
  // descriptor of L2 norm `query_norm` (AssembleShardAnswers), with the joint distances of
  // the shard whose joint representation fits best (SetJoint); counts and reports the
  // shards whose distances cannot be exact. Caller holds mutex_.
  Query Assemble(const QueryHeader& header, double query_norm,
                 const std::vector<const ShardDistances*>& answers) REQUIRES(mutex_);
  // Queues the queries the join released for the callbacks. Caller holds mutex_.
  void Queue(std::vector<Join::Release> releases) REQUIRES(mutex_);
  // Hands the queued queries to the callbacks, in order. Called without mutex_.
  void Deliver() EXCLUDES(mutex_, deliver_);
  // Deliver() soon, from the node's callback queue (for a caller that holds the node's
  // lock, which the callbacks take).
  void DeliverLater();
  // Routes a load or unload to shard k (waiting `timeout_s` for its answer) and waits for
  // its new shard_info. Without mutex_.
  template <typename Service>
  std::string Route(int k, const std::string& service, Service* srv, double timeout_s)
      EXCLUDES(mutex_);
  int OwnerOf(const std::string& set) const REQUIRES(mutex_);  // -1 if none
  int LeastLoaded() const REQUIRES(mutex_);                    // -1 if none published
  bool CanAnswer(int k) const REQUIRES(mutex_);
  std::string MissingSummaryLocked() const REQUIRES(mutex_);

  ros::NodeHandle nh_;
  const ShardedMapOptions options_;
  Callbacks callbacks_;  // set once by Start, before any subscription
  // Held while a callback runs: one at a time, in order (taken before mutex_).
  Mutex deliver_ ACQUIRED_BEFORE(mutex_);
  mutable Mutex mutex_;
  // The kind the method asked for, and whose the last query took.
  std::optional<JointKind> joint_kind_ GUARDED_BY(mutex_);
  bool calibration_asked_ GUARDED_BY(mutex_) = false;  // SetCalibration
  std::string joint_used_ GUARDED_BY(mutex_);
  std::condition_variable infos_changed_;  // a shard_info taken or refused
  std::vector<Shard> shards_ GUARDED_BY(mutex_);
  Join join_ GUARDED_BY(mutex_);
  Layout layout_ GUARDED_BY(mutex_);
  uint64_t generations_ GUARDED_BY(mutex_) = 0;  // layouts made
  DistanceMetric metric_ GUARDED_BY(mutex_);
  int64_t decided_ GUARDED_BY(mutex_) = 0;
  int64_t decided_partial_ GUARDED_BY(mutex_) = 0;
  int64_t layouts_ GUARDED_BY(mutex_) = 0;
  std::deque<Outgoing> outbox_ GUARDED_BY(mutex_);
  ros::WallTimer timer_;
  // shard_info and its confirmation (service calls) on a queue and thread of their own.
  ros::CallbackQueue info_queue_;
  std::unique_ptr<ros::AsyncSpinner> info_spinner_;
  ros::WallTimer confirm_timer_;  // on info_queue_
};

}  // namespace bsf_vpr
