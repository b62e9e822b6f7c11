#include "src/ros/fusion/odometry_tracker.h"

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
                                 std::string base_frame)
    : source_(source), odom_frame_(std::move(odom_frame)), base_frame_(std::move(base_frame)) {
  if (source_ == OdometrySource::kTopic) {
    sub_ = nh.subscribe(topic, 50, &OdometryTracker::OnOdometry, this);
  } else if (source_ == OdometrySource::kTf) {
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
  }
}

void OdometryTracker::OnOdometry(const nav_msgs::Odometry::ConstPtr& msg) {
  const auto& p = msg->pose.pose.position;
  std::lock_guard<std::mutex> lock(mutex_);
  latest_ = Eigen::Vector3d(p.x, p.y, p.z);
}

std::optional<Eigen::Vector3d> OdometryTracker::Position(const ros::Time& stamp) {
  if (source_ == OdometrySource::kTopic) {
    std::lock_guard<std::mutex> lock(mutex_);
    return latest_;
  }
  for (const ros::Time& t : {stamp, ros::Time(0)}) {  // at the image's time, else the latest
    try {
      const auto tr = tf_buffer_->lookupTransform(odom_frame_, base_frame_, t);
      return Eigen::Vector3d(tr.transform.translation.x, tr.transform.translation.y,
                             tr.transform.translation.z);
    } catch (const tf2::TransformException&) {
    }
  }
  return std::nullopt;
}

std::optional<double> OdometryTracker::StepPlaces(const ros::Time& stamp, double spacing_m) {
  if (source_ == OdometrySource::kNone) return std::nullopt;
  const std::optional<Eigen::Vector3d> now = Position(stamp);
  if (!now) {
    ROS_WARN_THROTTLE(5.0, "bsf_vpr: no odometry yet (%s); the filter uses its step distribution",
                      ToString(source_).c_str());
    return std::nullopt;
  }
  std::optional<double> step;
  std::lock_guard<std::mutex> lock(mutex_);
  if (spacing_m <= 0) {
    ROS_WARN_THROTTLE(5.0,
                      "bsf_vpr: odometry without place spacing: set place_spacing_m or "
                      "load reference sets with poses");
  } else if (at_last_query_) {
    step = (*now - *at_last_query_).norm() / spacing_m;
  }
  at_last_query_ = now;
  return step;
}

}  // namespace bsf_vpr
