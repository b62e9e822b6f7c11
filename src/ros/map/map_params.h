// The parameters of a map a fusion node or shard holds (MapParams), of a sharded map
// (ShardingParams), and the configured sets' list, each part with its table (bsf_options
// writes config/, cfg/ and docs/options.md from the tables).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/place_layout.h"
#include "src/ros/common/param_util.h"

namespace bsf_vpr {

struct ReferenceSetEntry {
  std::string name;       // required for a .npy; overrides a YAML's name if set
  std::string path;       // descriptor .npy or reference-set .yaml
  std::string condition;  // optional
};

// The parameters of a map whose sets live in this process: a fusion node's own sets, a
// fusion shard's (MapParamsTable()).
struct MapParams {
  std::vector<ReferenceSetEntry> reference_sets;
  std::string data_directory;  // services read and write files only below it (created)
  // The distance configured; none (parameter ""): the distance the sets loaded at start
  // declare, or the first set loaded into an empty map.
  std::optional<DistanceMetric> distance;
  StoragePrecision storage = StoragePrecision::kFloat32;  // of every set loaded
  bool memory_map = false;             // map .npy files held at `storage` instead of reading them
  double place_pose_tolerance_m = kDefaultPlacePoseToleranceM;  // sets disagreeing more on a place's pose are refused

  bool distance_given() const { return distance.has_value(); }
};

// A sharded map (sharded_map.h): the shards whose distances this node fuses instead of
// holding sets of its own; a query waits shard_timeout for the shards that have not
// answered after the first did (ShardingParamsTable()).
struct ShardingParams {
  std::vector<std::string> shards;
  double shard_timeout = 0.5;
  double shard_call_timeout = 0.5;  // beyond shard_timeout
  double shard_load_timeout = 30;
};

const OptionTable<MapParams>& MapParamsTable();
const OptionTable<ShardingParams>& ShardingParamsTable();

// reference_sets (a list of {name, path, condition}) and shards (a list of names), read by
// code of their own. Throw std::invalid_argument naming the entry that is wrong.
std::vector<ReferenceSetEntry> LoadReferenceSetEntries(RosParamSource& source);
std::vector<std::string> LoadShardNames(RosParamSource& source);

}  // namespace bsf_vpr
