#include "robot_pose.h"

#include <cmath>

namespace bsf_vpr {

PlacePose ToPlacePose(double x, double y, double z, double qx, double qy, double qz, double qw) {
  PlacePose p;
  p.x_m = x;
  p.y_m = y;
  p.z_m = z;
  p.yaw_rad = std::atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz));
  return p;
}

RobotPoseSource::RobotPoseSource(ros::NodeHandle nh, const std::string& source,
                                 const std::string& topic, std::string map_frame,
                                 std::string base_frame)
    : source_(source),
      topic_(topic),
      map_frame_(std::move(map_frame)),
      base_frame_(std::move(base_frame)) {
  if (source_ == "tf") {
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  } else if (source_ == "topic") {
    sub_ = nh.subscribe(topic, 10, &RobotPoseSource::OnOdometry, this);
  }
}

std::string RobotPoseSource::Describe() const {
  if (source_ == "tf") return "tf " + map_frame_ + " -> " + base_frame_;
  if (source_ == "topic") return "topic " + topic_;
  return "nowhere (pose_source none)";
}

void RobotPoseSource::OnOdometry(const nav_msgs::Odometry::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  latest_ = msg;
}

std::optional<PlacePose> RobotPoseSource::PoseAt(const ros::Time& stamp) {
  if (tf_buffer_) {
    try {
      const geometry_msgs::TransformStamped t =
          tf_buffer_->lookupTransform(map_frame_, base_frame_, stamp);
      const auto& v = t.transform.translation;
      const auto& q = t.transform.rotation;
      return ToPlacePose(v.x, v.y, v.z, q.x, q.y, q.z, q.w);
    } catch (const tf2::TransformException&) {
      return std::nullopt;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!latest_ || std::abs((latest_->header.stamp - stamp).toSec()) > 1.0) return std::nullopt;
  const auto& p = latest_->pose.pose;
  return ToPlacePose(p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
                     p.orientation.z, p.orientation.w);
}

}  // namespace bsf_vpr
