// descriptor_ingest as a plain node (the same class the nodelet wraps).
#include <ros/ros.h>

#include "src/ros/ingest/descriptor_ingest.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "descriptor_ingest");
  bsf_vpr::DescriptorIngest ingest(ros::NodeHandle(), ros::NodeHandle("~"));
  try {
    ingest.Start();
  } catch (const std::exception& e) {
    ROS_FATAL("bsf_vpr descriptor_ingest cannot start: %s", e.what());
    return 1;
  }
  ros::spin();
  return 0;
}
