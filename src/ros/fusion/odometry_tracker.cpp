#include "src/ros/fusion/odometry_tracker.h"

#include <cstdio>
#include <stdexcept>

namespace bsf_vpr {

const EnumNames<OdometrySource>& OdometrySourceNames() {
  static const EnumNames<OdometrySource> kNames{{OdometrySource::kNone, "none"},
                                                {OdometrySource::kTopic, "topic"},
                                                {OdometrySource::kTf, "tf"}};
  return kNames;
}

OdometrySource ParseOdometrySource(const std::string& text) {
  return OdometrySourceNames().Parse(text, "odometry_source");
}

std::string ToString(OdometrySource source) { return OdometrySourceNames().Name(source); }

OdometryTracker::OdometryTracker(ros::NodeHandle nh, OdometrySource source,
                                 const std::string& topic, std::string odom_frame,
                                 std::string base_frame, double timeout_s)
    : source_(source),
      odom_frame_(std::move(odom_frame)),
      base_frame_(std::move(base_frame)),
      progress_(timeout_s) {
  if (source_ == OdometrySource::kTopic) {
    sub_ = nh.subscribe(topic, 50, &OdometryTracker::OnOdometry, this);
  } else if (source_ == OdometrySource::kTf) {
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
  }
}

void OdometryTracker::OnOdometry(const nav_msgs::Odometry::ConstPtr& msg) {
  const auto& p = msg->pose.pose.position;
  MutexLock lock(&mutex_);
  // Heard on the node's clock: a stamp may be zero or from another machine's clock.
  if (!progress_.Hear(Eigen::Vector3d(p.x, p.y, p.z), ros::Time::now().toSec())) {
    ROS_WARN_THROTTLE(1.0,
                      "bsf_vpr: refused an odometry message whose position is not finite "
                      "(%g, %g, %g); %lu refused so far, the last finite one is kept",
                      p.x, p.y, p.z, static_cast<unsigned long>(progress_.refused()));
  }
}

void OdometryTracker::HearTf(const ros::Time& stamp) {
  for (const ros::Time& t : {stamp, ros::Time(0)}) {  // at the image's time, else the latest
    try {
      const auto tr = tf_buffer_->lookupTransform(odom_frame_, base_frame_, t);
      const auto& p = tr.transform.translation;
      progress_.Hear(Eigen::Vector3d(p.x, p.y, p.z), tr.header.stamp.toSec());
      return;
    } catch (const tf2::TransformException&) {
    }
  }
}

std::optional<double> OdometryTracker::StepPlaces(const ros::Time& stamp, double spacing_m) {
  if (source_ == OdometrySource::kNone) return std::nullopt;
  MutexLock lock(&mutex_);
  double now_s = ros::Time::now().toSec();
  if (source_ == OdometrySource::kTf) {
    HearTf(stamp);
    // tf is stamped: its age is the query's stamp's (the clock it was looked up at).
    if (!stamp.isZero()) now_s = stamp.toSec();
  }
  const OdometryProgress::State state = progress_.StateAt(now_s);
  if (state == OdometryProgress::State::kNone) {
    ROS_WARN_THROTTLE(5.0, "bsf_vpr: no odometry yet (%s); the filter uses its step distribution",
                      ToString(source_).c_str());
  } else if (state == OdometryProgress::State::kStale) {
    ROS_WARN_THROTTLE(5.0,
                      "bsf_vpr: odometry is stale (%s, last heard %.1f s before the query, "
                      "odometry_timeout_s %g); the filter uses its step distribution",
                      ToString(source_).c_str(), progress_.AgeAt(now_s).value_or(0.0),
                      progress_.timeout_s());
  } else if (!(spacing_m > 0)) {
    ROS_WARN_THROTTLE(5.0,
                      "bsf_vpr: odometry without place spacing: set place_spacing_m or "
                      "load reference sets with poses");
  }
  return progress_.StepPlaces(now_s, spacing_m);
}

std::string OdometryTracker::Problem() {
  if (source_ == OdometrySource::kNone) return "";
  MutexLock lock(&mutex_);
  const double now_s = ros::Time::now().toSec();
  switch (progress_.StateAt(now_s)) {
    case OdometryProgress::State::kNone:
      return "no odometry heard yet (" + ToString(source_) +
             "): the filter uses its step distribution";
    case OdometryProgress::State::kStale: {
      char text[200];
      std::snprintf(text, sizeof(text),
                    "odometry is stale (%s): last heard %.1f s ago, more than "
                    "odometry_timeout_s %g; the filter uses its step distribution",
                    ToString(source_).c_str(), progress_.AgeAt(now_s).value_or(0.0),
                    progress_.timeout_s());
      return text;
    }
    case OdometryProgress::State::kFresh:
      break;
  }
  return "";
}

void OdometryTracker::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  if (source_ == OdometrySource::kNone) return;
  MutexLock lock(&mutex_);
  const double now_s = ros::Time::now().toSec();
  static const char* const kStates[] = {"none heard", "fresh", "stale"};
  status.add("odometry", kStates[static_cast<int>(progress_.StateAt(now_s))]);
  if (const std::optional<double> age = progress_.AgeAt(now_s)) {
    status.addf("odometry age (s)", "%.2f", *age);
  }
  status.add("odometry refused: not finite", progress_.refused());
  status.add("queries on stale odometry", progress_.stale_steps());
}

}  // namespace bsf_vpr
