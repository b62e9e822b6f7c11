#include "src/ros/map/make_map.h"

#include <ros/console.h>

#include "src/ros/map/local_map.h"
#include "src/ros/map/sharded_map.h"

namespace bsf_vpr {

std::unique_ptr<MapBackend> MakeMap(const ros::NodeHandle& nh, const FusionParams& params,
                                    const DataDirectory* data_dir) {
  if (params.shards.empty()) {
    auto map = std::make_unique<LocalMap>(
        LocalMapOptions::From(params, params.recognizer.first_stage), data_dir);
    map->LoadConfigured(params.reference_sets,
                        params.data_directory.empty() ? "." : params.data_directory);
    return map;
  }
  if (!params.reference_sets.empty()) {
    throw std::invalid_argument(
        "a fusion node with shards fuses the shards' sets and holds none of its own: give "
        "reference_sets to the shards (docs/sharding.md)");
  }
  if (params.recognizer.first_stage.Kind() != FirstStageKind::kExact) {
    ROS_WARN("bsf_vpr: first_stage %s is the shards' parameter; the combiner computes no distances",
             params.recognizer.first_stage.kind.c_str());
  }
  ShardedMapOptions options;
  options.shards = params.shards;
  options.timeout_s = params.shard_timeout;
  options.call_timeout_s = params.shard_timeout + params.shard_call_timeout;
  options.load_timeout_s = params.shard_load_timeout;
  options.queue_size = params.queue_size;
  options.metric = params.distance;
  options.place_pose_tolerance_m = params.place_pose_tolerance_m;
  return std::make_unique<ShardedMap>(nh, std::move(options));
}

}  // namespace bsf_vpr
