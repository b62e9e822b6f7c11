// descriptor_ingest as a nodelet: its output reaches the fusion nodelet without a copy.
#include <pluginlib/class_list_macros.hpp>

#include "src/ros/common/node_runner.h"
#include "src/ros/ingest/descriptor_ingest.h"

namespace bsf_vpr {
constexpr char kIngestName[] = "descriptor_ingest";
using DescriptorIngestNodelet = NodeletOf<DescriptorIngest, kIngestName>;
}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::DescriptorIngestNodelet, nodelet::Nodelet)
