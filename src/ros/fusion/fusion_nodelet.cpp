// The fusion node as a nodelet, so that descriptors reach it from descriptor_ingest without
// being copied or serialised. MakeFusionNode hands it the map its parameters name.
#include <pluginlib/class_list_macros.hpp>

#include "src/ros/common/node_runner.h"
#include "src/ros/fusion/fusion_node.h"

namespace bsf_vpr {
constexpr char kFusionName[] = "fusion";
using FusionNodelet = NodeletOf<FusionNode, kFusionName, &MakeFusionNode>;
}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::FusionNodelet, nodelet::Nodelet)
