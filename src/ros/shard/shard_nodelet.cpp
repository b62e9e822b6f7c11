// A fusion shard as a nodelet, in the manager of the descriptor_ingest nodelet that feeds it.
#include <pluginlib/class_list_macros.hpp>

#include "src/ros/common/node_runner.h"
#include "src/ros/shard/shard_node.h"

namespace bsf_vpr {
constexpr char kShardName[] = "shard";
using ShardNodelet = NodeletOf<ShardNode, kShardName>;
}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::ShardNodelet, nodelet::Nodelet)
