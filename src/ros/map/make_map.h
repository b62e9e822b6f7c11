// The map a fusion node decides on, as its parameters say: the shards' (parameter shards,
// ShardedMap) or its own sets (LocalMap, loaded from reference_sets). The one place that
// tells the two apart.
#pragma once

#include <ros/node_handle.h>

#include <memory>

#include "bsf_vpr/io/data_directory.h"
#include "src/ros/fusion/fusion_params.h"
#include "src/ros/map/map_backend.h"

namespace bsf_vpr {

// Throws std::exception naming the problem (a configured set that cannot be read, sets
// given beside shards). `data_dir` (may be null) outlives the map, which calls back only
// once started (MapBackend::Start).
std::unique_ptr<MapBackend> MakeMap(const ros::NodeHandle& nh, const FusionParams& params,
                                    const DataDirectory* data_dir);

}  // namespace bsf_vpr
