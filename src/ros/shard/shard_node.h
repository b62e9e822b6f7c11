// A fusion shard: one part of a sharded map (docs/sharding.md). It holds some of the map's
// reference sets and, for every descriptor, publishes the exact distances of the query to
// each of them (bsf_vpr/ShardDistances on ~distances, stamped with the descriptor's header);
// a fusion node with the parameter `shards` (the combiner) fuses every shard's distances
// into the belief. The shard decides nothing: selection, fusion, the temporal prior and
// sequence matching are the combiner's, so that its belief is bitwise the single node's.
//
// Its parameters (ShardParamsTable: reference_sets, data_directory, distance, storage,
// place_pose_tolerance_m, first_stage* (a pca first stage is per shard and no longer
// bitwise the single node's), queue_size and diagnostic_period) are the fusion node's
// names for the same things; any other is refused at start. Its sets are a LocalMap, as a
// fusion node's own. What it holds is latched on
// ~shard_info (bsf_vpr/ShardInfo) and published again on every change; ~get_shard_info answers
// the same, with the shard's node name, so that the combiner can confirm a shard_info before it
// believes it (docs/ros.md, "Threat model"); ~list_reference_sets, ~load_reference_set,
// ~unload_reference_set and ~get_distances serve the combiner (and operators). The services
// are advertised before the first shard_info, so that a combiner can confirm it at once.
//
// The map has its own lock; mutex_ guards the shard's counters and what it publishes.
// load_reference_set reads its files on a thread of its own.
#pragma once

#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/GetShardDistances.h>
#include <bsf_vpr/GetShardInfo.h>
#include <bsf_vpr/ListReferenceSets.h>
#include <bsf_vpr/LoadReferenceSet.h>
#include <bsf_vpr/ShardDistances.h>
#include <bsf_vpr/UnloadReferenceSet.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/map/local_map.h"
#include "src/ros/shard/shard_params.h"

namespace bsf_vpr {

class ShardNode {
 public:
  ShardNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~ShardNode();

  // Reads the parameters, loads the configured sets, publishes ~shard_info and starts
  // listening. Throws std::exception naming the problem if the shard cannot start.
  void Start();

 private:
  void OnDescriptor(const Descriptor::ConstPtr& msg) EXCLUDES(mutex_);
  // The shard's answer for `descriptor` (the map's own lock).
  ShardDistances Answer(const Descriptor& descriptor) const;
  // Publishes what the shard holds now (latched).
  void PublishInfo() REQUIRES(mutex_);
  // What the shard holds now.
  ShardInfo Info() const REQUIRES(mutex_);
  // A load or unload: `change` runs on the map (its message answers), then what the shard
  // holds is published; a refusal answers with its reason. Without mutex_.
  template <typename Response>
  void Change(const std::string& service, const std::function<std::string()>& change, Response* res)
      EXCLUDES(mutex_);
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) EXCLUDES(mutex_);

  bool OnList(ListReferenceSets::Request& req, ListReferenceSets::Response& res);
  bool OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res);
  bool OnUnload(UnloadReferenceSet::Request& req, UnloadReferenceSet::Response& res);
  bool OnCompute(GetShardDistances::Request& req, GetShardDistances::Response& res);
  bool OnInfo(GetShardInfo::Request& req, GetShardInfo::Response& res) EXCLUDES(mutex_);

  ros::NodeHandle nh_, pnh_;
  ShardParams params_;
  // Held while the shard publishes what it holds, and over the diagnostics' counts; the map
  // has a lock of its own.
  Mutex mutex_;
  std::unique_ptr<DataDirectory> data_dir_;  // null: load_reference_set is off
  std::unique_ptr<LocalMap> map_;            // the shard's sets; it decides nothing
  ros::CallbackQueue load_queue_;
  std::unique_ptr<ros::AsyncSpinner> load_spinner_;

  ros::Subscriber descriptor_sub_;
  ros::Publisher distances_pub_, info_pub_;
  std::vector<ros::ServiceServer> services_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::Timer diagnostics_timer_;

  // The map's layout generation last published in ~shard_info: the map may drop a set by
  // itself (its mapped file changed in place), and the combiner then learns of it.
  uint64_t published_generation_ GUARDED_BY(mutex_) = 0;
  // Since the last diagnostics update.
  int processed_ GUARDED_BY(mutex_) = 0;
  int rejected_ GUARDED_BY(mutex_) = 0;
  double processing_s_sum_ GUARDED_BY(mutex_) = 0;
  std::string last_rejection_ GUARDED_BY(mutex_);
  // The last descriptor_type that differs from the sets'.
  std::string type_mismatch_ GUARDED_BY(mutex_);
  ros::WallTime last_diagnostics_ GUARDED_BY(mutex_);
};

}  // namespace bsf_vpr
