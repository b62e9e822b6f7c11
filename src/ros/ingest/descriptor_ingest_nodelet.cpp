// descriptor_ingest as a nodelet: its output reaches the fusion nodelet without a copy.
#include <nodelet/nodelet.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>

#include "src/ros/ingest/descriptor_ingest.h"

namespace bsf_vpr {

class DescriptorIngestNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    ingest_ = std::make_unique<DescriptorIngest>(getNodeHandle(), getPrivateNodeHandle());
    try {
      ingest_->Start();
    } catch (const std::exception& e) {
      NODELET_FATAL("bsf_vpr descriptor_ingest cannot start: %s", e.what());
      throw;
    }
  }
  std::unique_ptr<DescriptorIngest> ingest_;
};

}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::DescriptorIngestNodelet, nodelet::Nodelet)
