// The map of a fusion node with the parameter `shards` (docs/sharding.md): it holds no
// descriptors. Each fusion shard latches what it holds on ~shard_info and answers every
// descriptor with its distances on ~distances; this map keeps the layout of every shard's
// sets (in the order of `shards`, each shard's sets in its order), joins the answers of one
// query by their stamp (ShardJoin) and hands each query on, with the layout it is for,
// through Callbacks::query. load_reference_set and unload_reference_set are routed to the
// shard concerned and answered once its new shard_info is in the layout.
//
// A shard that comes back holding other sets (another fingerprint) changes the layout; a
// shard's sets that cannot share the map with the others' are refused (the layout keeps
// them out) and tried again when another shard's change.
//
// Thread-safe: one lock guards the shards and the join; the callbacks are called without
// it, one at a time, in the order the queries were decided.
#pragma once

#include <bsf_vpr/ShardDistances.h>
#include <bsf_vpr/ShardInfo.h>
#include <ros/ros.h>

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "src/ros/map/map_backend.h"
#include "src/ros/map/shard_join.h"

namespace bsf_vpr {

struct ShardedMapOptions {
  std::vector<std::string> shards;  // resolved in the node's namespace
  double timeout_s = 0.5;           // a query waits this long for the shards after the first
  int queue_size = 100;             // queries pending at most
  // The distance the node is configured with (nullopt: the shards').
  std::optional<DistanceMetric> metric;
  double place_pose_tolerance_m = 25;
};

class ShardedMap : public MapBackend {
 public:
  ShardedMap(ros::NodeHandle nh, ShardedMapOptions options);
  ~ShardedMap() override;

  // Subscribes to the shards; queries and layouts are handed on from then on.
  void Start(Callbacks callbacks) override;
  bool NeedsDescriptors() const override { return false; }
  Layout layout() const override;
  DistanceMetric metric() const override;
  std::optional<Query> Hear(const Descriptor&) override { return std::nullopt; }
  Query Ask(const Descriptor& descriptor) override;
  std::string Load(const LoadReferenceSet::Request& request, const SetCheck& check) override;
  std::string Unload(const std::string& name) override;
  std::string Add(ReferenceSet set, const std::string& where) override;
  std::string CannotRecord() const override;
  void List(ListReferenceSets::Response* response) const override;
  std::string Problem() const override;
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const override;

 private:
  struct Shard {
    std::string name;
    ros::Subscriber info_sub, distances_sub;
    ShardInfo::ConstPtr info;  // the last taken; null before the first
    uint64_t info_count = 0;
    std::string refused;               // why its last shard_info was refused ("" if taken)
    ShardInfo::ConstPtr refused_info;  // that shard_info, tried again when the map changes
    uint64_t refusals = 0;
    bool change_expected = false;  // a load or unload was routed to it
    std::string lost;              // sets its last change dropped without one
  };
  using Join = ShardJoin<ShardDistances::ConstPtr>;
  // What the callbacks are to be told, in order: a query, a rejection or a layout.
  struct Outgoing {
    std::optional<Query> query;
    std::string rejection;
    Layout layout;
  };

  void OnInfo(int k, const ShardInfo::ConstPtr& msg);
  // OnInfo's work under mutex_ (a new layout is queued for the callbacks).
  void TakeShardInfo(int k, const ShardInfo::ConstPtr& msg);
  void OnDistances(int k, const ShardDistances::ConstPtr& msg);
  // Makes `msg` shard k's layout if it fits the others'; else keeps it as refused. Caller
  // holds mutex_.
  bool TakeInfo(int k, const ShardInfo::ConstPtr& msg);
  // Every shard's sets with shard k's from `info`, in the map's order, and their distance.
  // Throws std::invalid_argument when they cannot share a map. Caller holds mutex_.
  PlaceLayout LayoutWith(int k, const ShardInfo& info, DistanceMetric* metric) const;
  // The query of `answers` (one per shard, null where none) on the layout now. A shard's
  // refusal, or an answer that does not fit its sets, makes that shard missing; throws
  // std::invalid_argument when every shard that answered with sets refused the descriptor.
  // Caller holds mutex_.
  Query Assemble(const std_msgs::Header& header,
                 const std::vector<const ShardDistances*>& answers) const;
  // Queues the join's decisions for the callbacks. Caller holds mutex_.
  void Queue(std::vector<Join::Decision> decisions);
  // Hands the queued queries to the callbacks, in order. Called without mutex_.
  void Deliver();
  // Routes a load or unload to shard k and waits for its new shard_info. Without mutex_.
  template <typename Service>
  std::string Route(int k, const std::string& service, Service* srv);
  int OwnerOf(const std::string& set) const;  // caller holds mutex_; -1 if none
  int LeastLoaded() const;                    // caller holds mutex_; -1 if none published
  bool CanAnswer(int k) const;                // caller holds mutex_
  std::string MissingSummaryLocked() const;

  ros::NodeHandle nh_;
  const ShardedMapOptions options_;
  Callbacks callbacks_;  // set once by Start, before any subscription
  mutable std::mutex mutex_;
  std::condition_variable infos_changed_;  // a shard_info taken or refused
  std::vector<Shard> shards_;
  Join join_;
  Layout layout_;
  uint64_t generations_ = 0;  // layouts made
  DistanceMetric metric_;
  int64_t decided_ = 0, decided_partial_ = 0, layouts_ = 0;
  std::deque<Outgoing> outbox_;
  std::mutex deliver_;  // held while a callback runs: one at a time, in order
  ros::WallTimer timer_;
};

}  // namespace bsf_vpr
