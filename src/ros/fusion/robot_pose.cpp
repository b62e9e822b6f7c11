#include "src/ros/fusion/robot_pose.h"

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/core/place_layout.h"

namespace bsf_vpr {
namespace {

constexpr double kHistoryS = 30.0;     // how far back topic poses are kept
constexpr size_t kMaxSamples = 20000;  // and at most this many (a 500 Hz source)

PlacePose FromPose(const geometry_msgs::Pose& p) {
  return ToPlacePose(p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
                     p.orientation.z, p.orientation.w);
}

}  // namespace

const EnumNames<PoseSource>& PoseSourceNames() {
  static const EnumNames<PoseSource> kNames{
      {PoseSource::kTf, "tf"}, {PoseSource::kTopic, "topic"}, {PoseSource::kNone, "none"}};
  return kNames;
}

PoseSource ParsePoseSource(const std::string& text) {
  return PoseSourceNames().Parse(text, "pose_source");
}

std::string ToString(PoseSource source) { return PoseSourceNames().Name(source); }

const EnumNames<PoseLoss>& PoseLossNames() {
  static const EnumNames<PoseLoss> kNames{
      {PoseLoss::kNone, "none"},
      {PoseLoss::kNoSource, "no pose source"},
      {PoseLoss::kNotYet, "no pose received yet"},
      {PoseLoss::kNoTransform, "no transform between map_frame and base_frame"},
      {PoseLoss::kWaited, "no pose at or after the stamp within pose_wait_s"},
      {PoseLoss::kTooOld, "stamp older than the poses kept"},
      {PoseLoss::kGap, "gap in the poses around the stamp"},
      {PoseLoss::kFrame, "pose message in another frame"},
      {PoseLoss::kType, "pose message of another type"},
      {PoseLoss::kBadPose, "pose not finite or out of bounds"},
  };
  return kNames;
}

std::string ToString(PoseLoss loss) { return PoseLossNames().Name(loss); }

PlacePose ToPlacePose(double x, double y, double z, double qx, double qy, double qz, double qw) {
  PlacePose p;
  p.x_m = x;
  p.y_m = y;
  p.z_m = z;
  p.yaw_rad = std::atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz));
  return p;
}

RobotPoseSource::RobotPoseSource(ros::NodeHandle nh, RobotPoseOptions options)
    : options_(std::move(options)) {
  if (options_.source == PoseSource::kTf) {
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  } else if (options_.source == PoseSource::kTopic) {
    ros::NodeHandle own(nh);
    own.setCallbackQueue(&queue_);
    sub_ = own.subscribe(options_.topic, 100, &RobotPoseSource::OnMessage, this);
    spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
    spinner_->start();
  }
}

RobotPoseSource::~RobotPoseSource() {
  if (spinner_) spinner_->stop();
  sub_.shutdown();
}

std::string RobotPoseSource::Describe() const {
  switch (options_.source) {
    case PoseSource::kTf:
      return "tf " + options_.map_frame + " -> " + options_.base_frame;
    case PoseSource::kTopic:
      return "topic " + sub_.getTopic();
    case PoseSource::kNone:
      break;
  }
  return "nowhere (pose_source none)";
}

void RobotPoseSource::OnMessage(const topic_tools::ShapeShifter::ConstPtr& msg) {
  const std::string& type = msg->getDataType();
  std_msgs::Header header;
  PlacePose pose;
  try {
    if (type == "nav_msgs/Odometry") {
      const auto m = msg->instantiate<nav_msgs::Odometry>();
      header = m->header;
      pose = FromPose(m->pose.pose);
    } else if (type == "geometry_msgs/PoseStamped") {
      const auto m = msg->instantiate<geometry_msgs::PoseStamped>();
      header = m->header;
      pose = FromPose(m->pose);
    } else if (type == "geometry_msgs/PoseWithCovarianceStamped") {
      const auto m = msg->instantiate<geometry_msgs::PoseWithCovarianceStamped>();
      header = m->header;
      pose = FromPose(m->pose.pose);
    } else {
      MutexLock lock(&mutex_);
      bad_loss_ = PoseLoss::kType;
      bad_message_ = sub_.getTopic() + " carries " + type +
                     "; pose_topic takes nav_msgs/Odometry, geometry_msgs/PoseStamped or "
                     "geometry_msgs/PoseWithCovarianceStamped";
      return;
    }
  } catch (const std::exception& e) {
    MutexLock lock(&mutex_);
    bad_loss_ = PoseLoss::kType;
    bad_message_ = std::string("unreadable pose message: ") + e.what();
    return;
  }
  MutexLock lock(&mutex_);
  const std::string frame = header.frame_id.size() > 1 && header.frame_id[0] == '/'
                                ? header.frame_id.substr(1)
                                : header.frame_id;
  if (!frame.empty() && frame != options_.map_frame) {
    bad_loss_ = PoseLoss::kFrame;
    bad_message_ = sub_.getTopic() + " is in frame '" + frame + "', not map_frame '" +
                   options_.map_frame + "'";
    return;
  }
  const std::string problem = PoseProblem(pose);
  if (!problem.empty()) {
    bad_loss_ = PoseLoss::kBadPose;
    bad_message_ = sub_.getTopic() + " sent a pose that " + problem;
    return;
  }
  if (!samples_.empty() && header.stamp < samples_.back().stamp) {
    // Time went back far (a bag played again, a restarted simulation): the history is
    // another. A message only a little late (a second publisher, a delay) is left out.
    if ((samples_.back().stamp - header.stamp).toSec() <= options_.max_gap_s) return;
    samples_.clear();
  }
  samples_.push_back({header.stamp, pose});
  while (samples_.size() > kMaxSamples ||
         (samples_.back().stamp - samples_.front().stamp).toSec() > kHistoryS) {
    samples_.pop_front();
  }
  arrived_.notify_all();
}

PoseLookup RobotPoseSource::PoseAt(const ros::Time& stamp, double wait_s) {
  PoseLookup out;
  switch (options_.source) {
    case PoseSource::kTf:
      out = FromTf(stamp, wait_s);
      break;
    case PoseSource::kTopic:
      out = FromTopic(stamp, wait_s);
      break;
    case PoseSource::kNone:
      out.loss = PoseLoss::kNoSource;
      out.detail = "pose_source is none";
      break;
  }
  if (!out.pose && out.cause.empty()) out.cause = ToString(out.loss);
  MutexLock lock(&problem_mutex_);
  last_cause_ = out.pose ? "" : out.cause;
  losses_in_row_ = out.pose ? 0 : losses_in_row_ + 1;
  return out;
}

std::string RobotPoseSource::Problem() const {
  MutexLock lock(&problem_mutex_);
  if (last_cause_.empty()) return "";
  return "no pose from " + Describe() + " for the last " + std::to_string(losses_in_row_) +
         " descriptor(s): " + last_cause_;
}

std::string RobotPoseSource::TfDisconnection() const {
  const std::string& map = options_.map_frame;
  const std::string& base = options_.base_frame;
  if (tf_buffer_->canTransform(map, base, ros::Time(0), ros::Duration(0))) return "";
  const std::string head = "no transform from '" + map + "' to '" + base + "': ";
  if (!tf_buffer_->_frameExists(map)) return head + "frame '" + map + "' does not exist";
  if (!tf_buffer_->_frameExists(base)) return head + "frame '" + base + "' does not exist";
  const auto root = [&](std::string frame) {
    std::string parent;
    for (int i = 0; i < 100 && tf_buffer_->_getParent(frame, ros::Time(0), parent); ++i) {
      frame = parent;
    }
    return frame;
  };
  // (The map frame may exist only as the parent of this node's own frames, vpr_place.)
  return head + "'" + base + "' is in the tf tree of '" + root(base) +
         "', which nothing connects to '" + map + "' (tree of '" + root(map) + "')";
}

PoseLookup RobotPoseSource::FromTf(const ros::Time& stamp, double wait_s) {
  std::string error;
  PoseLookup out;
  // Waits only for a pose that is on its way: tf has the frames, and its latest sample is
  // less than max_gap_s before the stamp. Otherwise the answer is at once, so that a missing
  // localiser costs recognition nothing.
  if (!tf_buffer_->canTransform(options_.map_frame, options_.base_frame, stamp, ros::Duration(0),
                                &error)) {
    // A frame missing is said so, not as tf's error at the stamp (which may be an
    // extrapolation in a tree the other frame is not part of).
    const std::string disconnected = TfDisconnection();
    if (!disconnected.empty()) {
      std::vector<std::string> frames;
      tf_buffer_->_getFrameStrings(frames);
      std::string known;
      for (size_t i = 0; i < frames.size() && i < 20; ++i) {
        known += (i ? ", " : "") + frames[i];
      }
      out.loss = PoseLoss::kNoTransform;
      out.cause = disconnected;
      out.detail = disconnected + " (tf has the frames: " +
                   (frames.empty() ? std::string("none") : known) +
                   (frames.size() > 20 ? ", ..." : "") + ")";
      return out;
    }
    const bool coming =
        error.find("future") != std::string::npos || error.find("only time") != std::string::npos;
    ros::Time latest;
    try {
      latest = tf_buffer_->lookupTransform(options_.map_frame, options_.base_frame, ros::Time(0))
                   .header.stamp;
    } catch (const tf2::TransformException&) {
    }
    const bool recent = !latest.isZero() && (stamp - latest).toSec() < options_.max_gap_s;
    if (!(coming && recent) || wait_s <= 0 ||
        !tf_buffer_->canTransform(options_.map_frame, options_.base_frame, stamp,
                                  ros::Duration(wait_s), &error)) {
      out.detail = error;
      if (latest.isZero()) {
        out.loss = PoseLoss::kNotYet;  // the frames are not (yet) connected
      } else if (stamp < latest && !coming) {
        out.loss = PoseLoss::kTooOld;
      } else if (!recent) {
        out.loss = PoseLoss::kGap;
        out.detail = "the latest tf is " + std::to_string((stamp - latest).toSec()) +
                     " s older than the descriptor (" + error + ")";
      } else {
        out.loss = PoseLoss::kWaited;
      }
      return out;
    }
  }
  try {
    const geometry_msgs::TransformStamped t =
        tf_buffer_->lookupTransform(options_.map_frame, options_.base_frame, stamp);
    const auto& v = t.transform.translation;
    const auto& q = t.transform.rotation;
    const PlacePose p = ToPlacePose(v.x, v.y, v.z, q.x, q.y, q.z, q.w);
    const std::string problem = PoseProblem(p);
    if (!problem.empty()) {
      out.loss = PoseLoss::kBadPose;
      out.detail = "tf gave a pose that " + problem;
      return out;
    }
    out.pose = p;
  } catch (const tf2::TransformException& e) {
    out.loss = PoseLoss::kWaited;
    out.detail = e.what();
  }
  return out;
}

PoseLookup RobotPoseSource::FromTopic(const ros::Time& stamp, double wait_s) {
  MutexLock lock(&mutex_);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  // Wait (on the wall clock: the poses come in real time) for a sample at or after the stamp,
  // only while poses flow: the newest less than max_gap_s before the stamp. Otherwise the
  // answer is at once, so that a missing localiser costs recognition nothing.
  if (!samples_.empty() && (stamp - samples_.back().stamp).toSec() < options_.max_gap_s) {
    lock.AwaitUntil(arrived_, deadline, [&] {
      mutex_.AssertHeld();
      return samples_.back().stamp >= stamp;
    });
  }
  PoseLookup out;
  if (samples_.empty()) {
    out.loss = bad_loss_ != PoseLoss::kNone ? bad_loss_ : PoseLoss::kNotYet;
    if (bad_loss_ == PoseLoss::kNone) {
      out.cause = sub_.getNumPublishers() == 0 ? "no publisher on " + sub_.getTopic()
                                               : "nothing received on " + sub_.getTopic();
    } else if (bad_loss_ != PoseLoss::kBadPose) {  // (a bad pose's message holds its value)
      out.cause = bad_message_;  // names the frame or type
    }
    out.detail = bad_message_.empty() ? "nothing on " + sub_.getTopic() : bad_message_;
    return out;
  }
  if (samples_.back().stamp < stamp) {
    out.loss = (stamp - samples_.back().stamp).toSec() < options_.max_gap_s ? PoseLoss::kWaited
                                                                            : PoseLoss::kGap;
    out.detail = "the newest pose on " + sub_.getTopic() + " is " +
                 std::to_string((stamp - samples_.back().stamp).toSec()) +
                 " s older than the descriptor after waiting " + std::to_string(wait_s) + " s";
    return out;
  }
  if (samples_.front().stamp > stamp) {
    out.loss = PoseLoss::kTooOld;
    out.detail = "the descriptor is older than the oldest pose kept";
    return out;
  }
  PoseTrack track;
  // The two samples around the stamp (the track is ascending).
  auto after = std::lower_bound(samples_.begin(), samples_.end(), stamp,
                                [](const Sample& s, const ros::Time& t) { return s.stamp < t; });
  auto before = after;
  if (after->stamp > stamp) --before;  // after != begin: front().stamp <= stamp
  for (auto it = before; it != std::next(after); ++it) {
    track.stamps_s.push_back(it->stamp.toSec());
    track.poses.push_back(it->pose);
  }
  out.pose = InterpolatePose(track, stamp.toSec(), options_.max_gap_s);
  if (!out.pose) {
    out.loss = PoseLoss::kGap;
    out.detail = "the poses around the stamp are " +
                 std::to_string((after->stamp - before->stamp).toSec()) + " s apart";
  }
  return out;
}

}  // namespace bsf_vpr
