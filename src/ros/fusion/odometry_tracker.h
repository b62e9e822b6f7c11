// The robot's progress between two queries, from odometry, for the +filter step of the
// fusion node: nav_msgs/Odometry on a topic, or the tf transform odom_frame -> base_frame.
//
// Thread-safe: the odometry callback and StepPlaces may run on different threads.
#pragma once

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <Eigen/Core>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "bsf_vpr/core/enum_names.h"

namespace bsf_vpr {

enum class OdometrySource { kNone, kTopic, kTf };

// The sources' names (odometry_source).
const EnumNames<OdometrySource>& OdometrySourceNames();
// A name of OdometrySourceNames(); throws std::invalid_argument naming the choices otherwise.
OdometrySource ParseOdometrySource(const std::string& text);
std::string ToString(OdometrySource source);

class OdometryTracker {
 public:
  // Subscribes to `topic` (kTopic) or listens to tf (kTf); kNone does nothing.
  OdometryTracker(ros::NodeHandle nh, OdometrySource source, const std::string& topic,
                  std::string odom_frame, std::string base_frame);

  // The distance travelled since the previous call, in places (metres / spacing_m), and
  // moves the reference position on. nullopt without odometry (none configured, none
  // received yet), without a spacing (spacing_m <= 0), or at the first call.
  std::optional<double> StepPlaces(const ros::Time& stamp, double spacing_m);

 private:
  void OnOdometry(const nav_msgs::Odometry::ConstPtr& msg);
  std::optional<Eigen::Vector3d> Position(const ros::Time& stamp);

  OdometrySource source_;
  std::string odom_frame_, base_frame_;
  ros::Subscriber sub_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::mutex mutex_;
  std::optional<Eigen::Vector3d> latest_;         // from the topic
  std::optional<Eigen::Vector3d> at_last_query_;  // where the previous query was made
};

}  // namespace bsf_vpr
