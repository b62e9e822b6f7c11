// The fusion node as a plain node (the same class the nodelet wraps).
#include <ros/ros.h>

#include "src/ros/fusion/fusion_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "fusion");
  bsf_vpr::FusionNode node(ros::NodeHandle(), ros::NodeHandle("~"));
  try {
    node.Start();
  } catch (const std::exception& e) {
    ROS_FATAL("bsf_vpr fusion cannot start: %s", e.what());
    return 1;
  }
  ros::spin();
  return 0;
}
