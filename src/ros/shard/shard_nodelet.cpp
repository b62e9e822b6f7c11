// A fusion shard as a nodelet, in the manager of the descriptor_ingest nodelet that feeds it.
#include <nodelet/nodelet.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>

#include "src/ros/shard/shard_node.h"

namespace bsf_vpr {

class ShardNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = std::make_unique<ShardNode>(getNodeHandle(), getPrivateNodeHandle());
    try {
      node_->Start();
    } catch (const std::exception& e) {
      NODELET_FATAL("bsf_vpr shard cannot start: %s", e.what());
      throw;
    }
  }
  std::unique_ptr<ShardNode> node_;
};

}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::ShardNodelet, nodelet::Nodelet)
