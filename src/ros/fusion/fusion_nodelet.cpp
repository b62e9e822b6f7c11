// The fusion node as a nodelet, so that descriptors reach it from descriptor_ingest without
// being copied or serialised.
#include <nodelet/nodelet.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>

#include "src/ros/fusion/fusion_node.h"

namespace bsf_vpr {

class FusionNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = std::make_unique<FusionNode>(getNodeHandle(), getPrivateNodeHandle());
    try {
      node_->Start();
    } catch (const std::exception& e) {
      NODELET_FATAL("bsf_vpr fusion cannot start: %s", e.what());
      throw;
    }
  }
  std::unique_ptr<FusionNode> node_;
};

}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::FusionNodelet, nodelet::Nodelet)
