// The robot's pose in the map frame, for recording a traversal by pose: from tf
// (map_frame -> base_frame at the descriptor's stamp) or from a nav_msgs/Odometry topic
// whose pose is in the map frame (e.g. a global robot_localization EKF fusing GPS).
#pragma once

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

class RobotPoseSource {
 public:
  // `source` is "tf", "topic" or "none" (FusionParams::pose_source).
  RobotPoseSource(ros::NodeHandle nh, const std::string& source, const std::string& topic,
                  std::string map_frame, std::string base_frame);

  // The pose at `stamp`: tf's transform at that time, or the latest odometry message if it
  // is at most 1 s older or newer. nullopt when there is none (never waits).
  std::optional<PlacePose> PoseAt(const ros::Time& stamp);
  const std::string& source() const { return source_; }
  // Where poses come from, for messages: "tf map -> base_link", "topic odometry/map".
  std::string Describe() const;

 private:
  void OnOdometry(const nav_msgs::Odometry::ConstPtr& msg);

  std::string source_, topic_, map_frame_, base_frame_;
  ros::Subscriber sub_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::mutex mutex_;
  nav_msgs::Odometry::ConstPtr latest_;
};

// Planar pose (x, y, z, yaw about z) of a position and orientation quaternion.
PlacePose ToPlacePose(double x, double y, double z, double qx, double qy, double qz, double qw);

}  // namespace bsf_vpr
