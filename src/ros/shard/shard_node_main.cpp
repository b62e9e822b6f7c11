// A fusion shard as a plain node (the same class the shard nodelet wraps).
#include <ros/ros.h>

#include "src/ros/shard/shard_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "shard");
  bsf_vpr::ShardNode node(ros::NodeHandle(), ros::NodeHandle("~"));
  try {
    node.Start();
  } catch (const std::exception& e) {
    ROS_FATAL("bsf_vpr shard cannot start: %s", e.what());
    return 1;
  }
  ros::spin();
  return 0;
}
