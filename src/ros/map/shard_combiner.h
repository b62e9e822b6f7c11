// The combiner's side of a sharded map (docs/sharding.md): a fusion node with the parameter
// `shards` holds no descriptors; it subscribes to each shard's ~shard_info (what the shard
// holds) and ~distances (each query's exact distances to its sets), pairs the answers of one
// query by their stamp, and hands them on, set by set in the map's order (shard by shard,
// each shard's sets in its order), once every shard expected has answered or shard_timeout
// after the first answer. Queries are handed on in stamp order, each once; a query whose
// stamp is older than the last one decided is handed on when every shard has answered it
// (a bag replayed again, descriptors published out of order), and is late otherwise.
//
// A shard is expected while it publishes and answers in time. One that stops publishing
// (its process ended) or misses a query is not waited for: its sets are missing from the
// queries that follow (Query::missing_shards), and it is expected again as soon as it
// answers a query in time. A shard that comes back holding other sets (another
// fingerprint) changes the map's layout; a layout the owner refuses is tried again when
// another shard's changes.
//
// Not thread-safe on its own: every callback takes the lock it is given, the owner's, and
// calls the owner's callbacks with it held; the owner calls the public members with it held.
#pragma once

#include <bsf_vpr/ShardDistances.h>
#include <bsf_vpr/ShardInfo.h>
#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

class ShardCombiner {
 public:
  struct Query {
    std_msgs::Header header;
    // Per set of the layout, in its order: 1 x N_u, or 0 x 0 where the set's shard did not
    // answer (PlaceRecognizer::RecognizeDistances takes it so).
    std::vector<RowMatrixXf> distances;
    // Shards holding sets without a usable answer, and shards not heard from yet.
    std::vector<std::string> missing_shards;
    double shard_seconds = 0;  // the slowest answering shard's own time
  };
  struct Callbacks {
    // The layout changed: `sets` (layout-only, every shard's in the map's order), compared
    // with `metric`; `why` says what changed. Throws to refuse it (the shard's info is
    // then ignored and the previous layout stays).
    std::function<void(std::vector<ReferenceSet> sets, DistanceMetric metric,
                       const std::string& why)>
        layout;
    std::function<void(Query& query)> query;             // a query to decide
    std::function<void(const std::string& why)> reject;  // a query that cannot be decided
  };

  // Subscribes to the shards, named as in the parameter `shards` (resolved in nh's
  // namespace). `lock` guards this object and the owner's state.
  ShardCombiner(ros::NodeHandle nh, const std::vector<std::string>& shards, double timeout_s,
                int queue_size, std::mutex* lock, Callbacks callbacks);

  int num_shards() const { return static_cast<int>(shards_.size()); }
  // The shard's resolved name, e.g. "/bsf_vpr/shard_0".
  const std::string& shard_name(int k) const { return shards_.at(static_cast<size_t>(k)).name; }
  // The shard holding the named set, or -1.
  int OwnerOf(const std::string& set) const;
  // The shard with shard_info holding the fewest places, or -1 when none has published.
  int LeastLoaded() const;
  // The named set as its shard describes it (null if no shard holds it).
  const ShardSet* SetInfo(const std::string& set) const;
  // How many shard_info messages of shard k were taken: a load or unload routed to it is
  // in the layout once this grows.
  uint64_t info_count(int k) const { return shards_.at(static_cast<size_t>(k)).info_count; }
  // How many of shard k's shard_info messages were refused, the last reason, and the sets
  // that refused shard_info added to the layout taken (to unload them again).
  uint64_t refusal_count(int k) const { return shards_.at(static_cast<size_t>(k)).refusals; }
  const std::string& refusal(int k) const { return shards_.at(static_cast<size_t>(k)).refused; }
  std::vector<std::string> RefusedNewSets(int k) const;
  // A load or unload is being routed to shard k: its next change of sets is expected (not
  // warned about as sets lost).
  void ExpectChange(int k);
  // The query of `answers` (one per shard, null where none), as the subscriptions assemble
  // it (for query_place). A shard's refusal, or an answer that does not fit its layout,
  // makes that shard missing; returns false with *error when every shard that answered
  // with sets refused the descriptor.
  bool Assemble(const std::vector<const ShardDistances*>& answers, Query* query,
                std::string* error) const;

  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const;
  // The shards not answering now, each with why ("" when all answer).
  std::string MissingSummary() const;

 private:
  struct Shard {
    std::string name;
    ros::Subscriber info_sub, distances_sub;
    ShardInfo::ConstPtr info;  // the last taken; null before the first
    uint64_t info_count = 0;
    bool missing = false;  // missed a query: not waited for until it answers again
    ros::WallTime missing_since;
    std::string refused;               // why its last shard_info was refused ("" if taken)
    ShardInfo::ConstPtr refused_info;  // that shard_info, tried again when the map changes
    uint64_t refusals = 0;
    bool change_expected = false;  // a load or unload was routed to it
    std::string lost;              // sets its last change dropped without one
    int64_t answered = 0, missed = 0, late = 0;
  };
  struct Pending {
    std_msgs::Header header;
    std::vector<ShardDistances::ConstPtr> answers;  // one per shard
    ros::WallTime first;
  };

  void OnInfo(int k, const ShardInfo::ConstPtr& msg);
  // Every shard's sets with shard k's from `info`, in the map's order, and their distance.
  // Throws std::invalid_argument when they cannot share a map.
  std::vector<ReferenceSet> LayoutWith(int k, const ShardInfo& info, DistanceMetric* metric) const;
  // Makes `msg` shard k's layout if the owner takes it; else keeps it as refused.
  bool TakeInfo(int k, const ShardInfo::ConstPtr& msg);
  void OnDistances(int k, const ShardDistances::ConstPtr& msg);
  // Decides the oldest pending queries that are complete or timed out, in stamp order.
  void Flush(ros::WallTime now);
  bool Expected(int k) const;  // a query waits for shard k's answer
  void MarkAnswering(int k);

  ros::NodeHandle nh_;
  std::vector<Shard> shards_;
  ros::WallDuration timeout_;
  size_t queue_size_;
  std::mutex* lock_;
  Callbacks callbacks_;
  std::map<ros::Time, Pending> pending_;
  // Answers for stamps at or before last_decided_: late ones, or (when every shard's comes)
  // a query that came late on the wire from every shard (decided then, see OnDistances).
  std::map<ros::Time, Pending> past_;
  ros::Time last_decided_;  // zero before the first
  ros::WallTimer timer_;
  int64_t decided_ = 0, decided_partial_ = 0, layouts_ = 0;
};

}  // namespace bsf_vpr
