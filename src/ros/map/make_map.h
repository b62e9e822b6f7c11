// The map a fusion node decides on, as its parameters say: the shards' (parameter shards,
// ShardedMap) or its own sets (LocalMap, loaded from reference_sets). The one place that
// tells the two apart; the nodelet and the plain node call it and hand the map to the node.
#pragma once

#include <ros/node_handle.h>

#include <memory>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/map/local_map.h"
#include "bsf_vpr/map/map_backend.h"
#include "src/ros/map/map_params.h"

namespace bsf_vpr {

// Throws std::exception naming the problem (a configured set that cannot be read, sets
// given beside shards). `data_dir` (may be null) outlives the map, which calls back only
// once started (MapBackend::Start).
// The parameters come as the parts they are: the map's own, the sharding's, the first
// stage (a local map's) and the queue a sharded map keeps.
std::unique_ptr<MapBackend> MakeMap(const ros::NodeHandle& nh, const MapParams& map,
                                    const ShardingParams& sharding,
                                    const FirstStageOptions& first_stage, int queue_size,
                                    const DataDirectory* data_dir);

// A map of this process's options from a node's map parameters and its first stage; its
// reports go to the ROS log.
LocalMapOptions ToLocalMapOptions(const MapParams& params, const FirstStageOptions& first_stage);

// The configured sets with their paths resolved (ResolveConfiguredPath) below the data
// directory, or the working directory without one.
std::vector<ConfiguredSet> ResolveConfiguredSets(const MapParams& params);

// A map's report in the ROS log (ROS_INFO, ROS_WARN or ROS_ERROR), after `prefix`.
MapLog RosMapLog(const std::string& prefix = "");

}  // namespace bsf_vpr
