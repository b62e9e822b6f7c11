// The nodelet and the plain node of each of bsf_vpr's nodes, from one class: a class Node
// with Node(ros::NodeHandle nh, ros::NodeHandle pnh) and Start(), which reads the
// parameters and throws std::exception naming what keeps it from starting (model:
// robot_localization's ekf_localization_node.cpp and ekf_localization_nodelet.cpp). Once
// started, each joins the process's MasterWatch, which registers it again with a restarted
// ROS master.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <exception>
#include <memory>

#include "src/ros/common/master_watch.h"

namespace bsf_vpr {

// A nodelet holding one Node; `Name` (a char array) names it in the start-up error.
template <class Node, const char* Name>
class NodeletOf : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = std::make_unique<Node>(getNodeHandle(), getPrivateNodeHandle());
    try {
      node_->Start();
    } catch (const std::exception& e) {
      NODELET_FATAL("bsf_vpr %s cannot start: %s", Name, e.what());
      throw;
    }
    watch_ = std::make_unique<MasterWatch>(getPrivateNodeHandle().getNamespace());
  }
  std::unique_ptr<Node> node_;
  std::unique_ptr<MasterWatch> watch_;  // after node_: gone before it
};

// A node's main: runs one Node named `name` until shutdown; 1 if it cannot start.
template <class Node>
int RunNode(int argc, char** argv, const char* name) {
  ros::init(argc, argv, name);
  Node node(ros::NodeHandle(), ros::NodeHandle("~"));
  try {
    node.Start();
  } catch (const std::exception& e) {
    ROS_FATAL("bsf_vpr %s cannot start: %s", name, e.what());
    return 1;
  }
  MasterWatch watch(ros::NodeHandle("~").getNamespace());
  ros::spin();
  return 0;
}

}  // namespace bsf_vpr
