#include "src/tools/common/query_bag.h"

#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/QueryGroundTruth.h>
#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <sensor_msgs/image_encodings.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "src/tools/common/cli_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

std_msgs::Header Header(const ros::Time& stamp, const std::string& frame) {
  std_msgs::Header h;
  h.stamp = stamp;
  h.frame_id = frame;
  return h;
}

}  // namespace

QueryBagWriter::QueryBagWriter(std::string path, std::string query_topic, std::string pose_frame)
    : path_(std::move(path)),
      tmp_(path_ + ".tmp"),
      query_topic_(std::move(query_topic)),
      pose_frame_(std::move(pose_frame)) {
  CreateParentFolders(path_);
  try {
    bag_ = std::make_unique<rosbag::Bag>(tmp_, rosbag::bagmode::Write);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write bag '" + tmp_ + "': " + e.what());
  }
}

QueryBagWriter::~QueryBagWriter() {
  if (committed_) return;
  try {
    if (bag_) bag_->close();
  } catch (...) {
  }
  std::remove(tmp_.c_str());  // never leave half a bag behind
}

void QueryBagWriter::WriteImage(const ros::Time& stamp, const cv::Mat& bgr8) {
  if (bgr8.type() != CV_8UC3) throw std::invalid_argument("WriteImage takes an 8-bit BGR image");
  const std_msgs::Header h = Header(stamp, "camera");
  bag_->write(query_topic_, stamp,
              cv_bridge::CvImage(h, sensor_msgs::image_encodings::BGR8, bgr8).toImageMsg());
}

void QueryBagWriter::WriteDescriptor(const ros::Time& stamp, const float* values, int dimension,
                                     const std::string& descriptor_type) {
  Descriptor d;
  d.header = Header(stamp, "camera");
  d.descriptor_type = descriptor_type;
  d.data.assign(values, values + dimension);
  bag_->write(query_topic_, stamp, d);
}

void QueryBagWriter::WriteGroundTruth(const ros::Time& stamp, int query_index,
                                      const std::vector<int>& correct_places) {
  QueryGroundTruth g;
  g.header = Header(stamp, "camera");
  g.query_index = query_index;
  g.correct_places = correct_places;
  bag_->write(kGroundTruthTopic, stamp, g);
}

void QueryBagWriter::WritePose(const ros::Time& stamp, const PlacePose& pose) {
  geometry_msgs::PoseStamped ps;
  ps.header = Header(stamp, pose_frame_);
  ps.pose.position.x = pose.x_m;
  ps.pose.position.y = pose.y_m;
  ps.pose.position.z = pose.z_m;
  ps.pose.orientation.z = std::sin(pose.yaw_rad / 2);
  ps.pose.orientation.w = std::cos(pose.yaw_rad / 2);
  bag_->write(kQueryPoseTopic, stamp, ps);
}

void QueryBagWriter::Close() {
  if (!bag_ || !bag_->isOpen()) return;
  try {
    bag_->close();
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write bag '" + tmp_ + "': " + e.what());
  }
}

void QueryBagWriter::Commit() {
  Close();
  std::error_code ec;
  std::filesystem::rename(tmp_, path_, ec);
  if (ec)
    throw std::runtime_error("cannot rename '" + tmp_ + "' to '" + path_ + "': " + ec.message());
  committed_ = true;
}

}  // namespace tools
}  // namespace bsf_vpr
