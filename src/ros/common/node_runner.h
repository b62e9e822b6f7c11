// The nodelet and the plain node of each of bsf_vpr's nodes, from one class: a class Node
// made by `Make` (by default Node(ros::NodeHandle nh, ros::NodeHandle pnh); the fusion node
// is handed its map there) with Start(), which reads the parameters and throws
// std::exception naming what keeps it from starting (model:
// robot_localization's ekf_localization_node.cpp and ekf_localization_nodelet.cpp). Once
// started, each joins the process's MasterWatch, which registers it again with a restarted
// ROS master.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "src/ros/common/master_watch.h"

namespace bsf_vpr {

template <class Node>
std::unique_ptr<Node> ConstructNode(ros::NodeHandle nh, ros::NodeHandle pnh) {
  return std::make_unique<Node>(std::move(nh), std::move(pnh));
}
template <class Node>
using NodeMaker = std::unique_ptr<Node> (*)(ros::NodeHandle nh, ros::NodeHandle pnh);

// A nodelet holding one Node; `Name` (a char array) names it in the start-up error.
template <class Node, const char* Name, NodeMaker<Node> Make = &ConstructNode<Node>>
class NodeletOf : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = Make(getNodeHandle(), getPrivateNodeHandle());
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

// Waits (at most timeout_s, on the wall clock) until rosout has connected to this node's
// /rosout publisher: what is logged before is printed but never reaches /rosout (nor
// rqt_console, nor the log of a remote operator), and a node logs what it loaded and
// which options it refused when it starts. The probe shares the log appender's publication
// (one per topic in a process), so its subscribers are the appender's. Without a rosout
// node on the master (rostest starts none) it does not wait.
inline void WaitForRosout(const ros::NodeHandle& nh, double timeout_s) {
  std::vector<std::string> nodes;
  if (!ros::master::getNodes(nodes) ||
      std::find(nodes.begin(), nodes.end(), "/rosout") == nodes.end()) {
    return;
  }
  ros::NodeHandle own(nh);
  const ros::Publisher probe = own.advertise<rosgraph_msgs::Log>("/rosout", 0);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (probe.getNumSubscribers() == 0 && ros::ok() && ros::WallTime::now() < deadline) {
    ros::WallDuration(0.01).sleep();
  }
}

// A node's main: runs one Node named `name` until shutdown; 1 if it cannot start.
template <class Node, NodeMaker<Node> Make = &ConstructNode<Node>>
int RunNode(int argc, char** argv, const char* name) {
  // Line-buffered, so that the console log reaches a file (nohup, a redirection) as it is
  // written, not when the buffer fills or the node ends.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  ros::init(argc, argv, name);
  const ros::NodeHandle handle;  // starts the node: its /rosout publisher among the first
  WaitForRosout(handle, 3.0);
  const std::unique_ptr<Node> node = Make(ros::NodeHandle(), ros::NodeHandle("~"));
  try {
    node->Start();
  } catch (const std::exception& e) {
    ROS_FATAL("bsf_vpr %s cannot start: %s", name, e.what());
    return 1;
  }
  MasterWatch watch(ros::NodeHandle("~").getNamespace());
  ros::spin();
  return 0;
}

}  // namespace bsf_vpr
