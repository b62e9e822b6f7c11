#include "src/ros/map/make_map.h"

#include <ros/console.h>

#include "src/ros/map/configured_paths.h"
#include "src/ros/map/sharded_map.h"

namespace bsf_vpr {

MapLog RosMapLog(const std::string& prefix) {
  return [prefix](LogLevel level, const std::string& message) {
    switch (level) {
      case LogLevel::kInfo:
        ROS_INFO("bsf_vpr: %s%s", prefix.c_str(), message.c_str());
        break;
      case LogLevel::kWarn:
        ROS_WARN("bsf_vpr: %s%s", prefix.c_str(), message.c_str());
        break;
      case LogLevel::kError:
        ROS_ERROR("bsf_vpr: %s%s", prefix.c_str(), message.c_str());
        break;
    }
  };
}

LocalMapOptions ToLocalMapOptions(const MapParams& params, const FirstStageOptions& first_stage) {
  LocalMapOptions o;
  o.metric = params.distance;
  o.storage = params.storage;
  o.memory_map = params.memory_map;
  o.place_pose_tolerance_m = params.place_pose_tolerance_m;
  o.first_stage = first_stage;
  o.log = RosMapLog();
  return o;
}

std::vector<ConfiguredSet> ResolveConfiguredSets(const MapParams& params) {
  const std::string base = params.data_directory.empty() ? "." : params.data_directory;
  std::vector<ConfiguredSet> out;
  for (const ReferenceSetEntry& e : params.reference_sets) {
    out.push_back({ResolveConfiguredPath(base, e.path), e.name, e.condition});
  }
  return out;
}

std::unique_ptr<MapBackend> MakeMap(const ros::NodeHandle& nh, const MapParams& map,
                                    const ShardingParams& sharding,
                                    const FirstStageOptions& first_stage, int queue_size,
                                    const DataDirectory* data_dir) {
  if (sharding.shards.empty()) {
    auto local = std::make_unique<LocalMap>(ToLocalMapOptions(map, first_stage), data_dir);
    local->LoadConfigured(ResolveConfiguredSets(map));
    return local;
  }
  if (!map.reference_sets.empty()) {
    throw std::invalid_argument(
        "a fusion node with shards fuses the shards' sets and holds none of its own: give "
        "reference_sets to the shards (docs/sharding.md)");
  }
  if (first_stage.Kind() != FirstStageKind::kExact) {
    ROS_WARN("bsf_vpr: first_stage %s is the shards' parameter; the combiner computes no distances",
             first_stage.kind.c_str());
  }
  ShardedMapOptions options;
  options.sharding = sharding;
  options.queue_size = queue_size;
  options.metric = map.distance;
  options.place_pose_tolerance_m = map.place_pose_tolerance_m;
  return std::make_unique<ShardedMap>(nh, std::move(options));
}

}  // namespace bsf_vpr
