#include "src/ros/fusion/fusion_node.h"
#include "src/ros/map/make_map.h"

namespace bsf_vpr {

std::unique_ptr<FusionNode> MakeFusionNode(ros::NodeHandle nh, ros::NodeHandle pnh) {
  const ros::NodeHandle map_nh = nh;
  return std::make_unique<FusionNode>(
      std::move(nh), std::move(pnh),
      [map_nh](const FusionParams& params, const DataDirectory* data_dir) {
        return MakeMap(map_nh, params, params, params.recognizer.first_stage, params.queue_size,
                       data_dir);
      });
}

}  // namespace bsf_vpr
