// The robot's progress between two queries, from odometry, for the +filter step of the
// fusion node: nav_msgs/Odometry on a topic, or the tf transform odom_frame -> base_frame.
// What it hears goes through OdometryProgress (odometry_progress.h): a non-finite position is
// refused (counted, warned), and odometry older than timeout_s is stale: the query gets no
// step (the filter's own step distribution) and diagnostics say so.
//
// Thread-safe: the odometry callback and StepPlaces may run on different threads.
#pragma once

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
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
#include "bsf_vpr/core/mutex.h"
#include "src/ros/fusion/odometry_progress.h"

namespace bsf_vpr {

enum class OdometrySource { kNone, kTopic, kTf };

// The sources' names (odometry_source).
const EnumNames<OdometrySource>& OdometrySourceNames();
// A name of OdometrySourceNames(); throws std::invalid_argument naming the choices otherwise.
OdometrySource ParseOdometrySource(const std::string& text);
std::string ToString(OdometrySource source);

class OdometryTracker {
 public:
  // Subscribes to `topic` (kTopic) or listens to tf (kTf); kNone does nothing. Odometry
  // last heard more than `timeout_s` ago is stale.
  OdometryTracker(ros::NodeHandle nh, OdometrySource source, const std::string& topic,
                  std::string odom_frame, std::string base_frame, double timeout_s);

  // The distance travelled since the previous call, in places (metres / spacing_m), and
  // moves the reference position on. nullopt without odometry (none configured, none
  // received yet, stale), without a spacing (spacing_m <= 0), or at the first call.
  std::optional<double> StepPlaces(const ros::Time& stamp, double spacing_m);

  // What is wrong with the odometry now ("" if nothing, or none is configured): stale, or
  // never heard.
  std::string Problem();
  // The odometry's state, age and counts, for the fusion node's diagnostics.
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

 private:
  void OnOdometry(const nav_msgs::Odometry::ConstPtr& msg);
  // Hears the tf transform at `stamp` (else the latest) into progress_.
  void HearTf(const ros::Time& stamp) REQUIRES(mutex_);

  OdometrySource source_;
  std::string odom_frame_, base_frame_;
  ros::Subscriber sub_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  Mutex mutex_;
  OdometryProgress progress_ GUARDED_BY(mutex_);
};

}  // namespace bsf_vpr
