// The robot's pose in the map frame at a descriptor's stamp, for recording by pose, as a
// robot's drivers give it: tf (map_frame -> base_frame) or a topic of
// nav_msgs/Odometry, geometry_msgs/PoseStamped or geometry_msgs/PoseWithCovarianceStamped
// (what bsf_import's bags, robot_localization and most localisers publish; the type is
// taken from the publisher). A camera image is usually newer than the last pose sample:
// PoseAt waits up to a given time for tf to reach the stamp, or for the topic's first message
// after it, and interpolates between the samples around the stamp. Nothing is
// extrapolated. It waits only while poses flow (the latest less than max_gap_s before the
// stamp): without a localiser it answers at once.
//
// Thread-safe. PoseAt blocks up to its wait: call it without holding a lock the pose's own
// callbacks need (they run on a queue and thread of their own).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <topic_tools/shape_shifter.h>

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>

#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

enum class PoseSource { kNone, kTf, kTopic };
// The sources' names (pose_source).
const EnumNames<PoseSource>& PoseSourceNames();
PoseSource ParsePoseSource(const std::string& text);  // throws naming the choices
std::string ToString(PoseSource source);

struct RobotPoseOptions {
  PoseSource source = PoseSource::kTf;
  std::string topic;  // kTopic: Odometry, PoseStamped or PoseWithCovarianceStamped
  std::string map_frame = "map", base_frame = "base_link";
  // Two topic samples farther apart than this are not interpolated between (a gap in the
  // poses; tf interpolates in its own cache); a latest pose older than this before the stamp
  // is not waited for.
  double max_gap_s = 1.0;
};

// Why there is no pose at a stamp: each is counted in the fusion node's diagnostics.
enum class PoseLoss {
  kNone,      // a pose was found
  kNoSource,  // pose_source none
  kNotYet,    // no pose at all has arrived yet
  kNoTransform,  // tf: map_frame and base_frame are not connected (a frame missing)
  kWaited,    // none at or after the stamp within wait_s (the poses lag the camera by more)
  kTooOld,    // the stamp is older than the poses kept
  kGap,       // the poses around (or before) the stamp are farther apart than max_gap_s
  kFrame,     // a message in another frame than map_frame
  kType,      // pose_topic carries another message type
  kBadPose    // a pose PoseProblem refuses (NaN, infinity, a coordinate beyond 1e8 m)
};
// The causes' short names ("no pose received yet").
const EnumNames<PoseLoss>& PoseLossNames();
std::string ToString(PoseLoss loss);

struct PoseLookup {
  std::optional<PlacePose> pose;
  PoseLoss loss = PoseLoss::kNone;
  // For a loss: the cause as counted (the diagnostics, a recording's losses), naming what is
  // missing when it is known ("no transform from 'map' to 'base_link': frame 'map' does not
  // exist", "no publisher on /odometry/map"), else ToString(loss). Holds no number, so that
  // the descriptors lost to one cause are counted together.
  std::string cause;
  std::string detail;  // for a loss: what was seen, for the log
};

class RobotPoseSource {
 public:
  RobotPoseSource(ros::NodeHandle nh, RobotPoseOptions options);
  ~RobotPoseSource();

  // The pose at `stamp`, waiting up to `wait_s` seconds for the sample after it (0: only
  // what has arrived).
  PoseLookup PoseAt(const ros::Time& stamp, double wait_s);
  PoseSource source() const { return options_.source; }
  // Where poses come from, for messages: "tf map -> base_link", "topic /odometry/map".
  std::string Describe() const;
  // Why the last PoseAt found no pose, with the number of lookups in a row that found none
  // ("" when it found one, or before the first): "no pose from tf map -> base_link for the
  // last 30 descriptors: no transform from 'map' to 'base_link': frame 'map' does not exist".
  std::string Problem() const;

 private:
  struct Sample {
    ros::Time stamp;
    PlacePose pose;
  };
  void OnMessage(const topic_tools::ShapeShifter::ConstPtr& msg);
  PoseLookup FromTf(const ros::Time& stamp, double wait_s);
  // Why tf has no transform map_frame -> base_frame at any time ("" when it has one): a
  // frame that does not exist, or two trees ("'base_link' is in the tf tree of 'odom',
  // which nothing connects to 'map' (tree of 'map')").
  std::string TfDisconnection() const;
  PoseLookup FromTopic(const ros::Time& stamp, double wait_s);

  RobotPoseOptions options_;
  // tf: the listener spins on a thread of its own.
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  // topic: a queue and thread of its own, so that PoseAt can wait for the next message.
  ros::CallbackQueue queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  ros::Subscriber sub_;
  Mutex mutex_;
  std::condition_variable arrived_;
  // Ascending stamps, the last kHistoryS seconds (.cpp).
  std::deque<Sample> samples_ GUARDED_BY(mutex_);
  // The last message refused (frame, type, not finite).
  std::string bad_message_ GUARDED_BY(mutex_);
  PoseLoss bad_loss_ GUARDED_BY(mutex_) = PoseLoss::kNone;
  mutable Mutex problem_mutex_;
  // Of the last lookup; "" when it found a pose.
  std::string last_cause_ GUARDED_BY(problem_mutex_);
  long losses_in_row_ GUARDED_BY(problem_mutex_) = 0;
};

// Planar pose (x, y, z, yaw about z) of a position and orientation quaternion.
PlacePose ToPlacePose(double x, double y, double z, double qx, double qy, double qz, double qw);

}  // namespace bsf_vpr
