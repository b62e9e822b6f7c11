// Query bags: a traversal as a bag that launch/replay.launch plays and bsf_evaluate
// --results-bag scores. One message per query (an image or a descriptor), with its ground
// truth and pose on their own topics under the query's stamp. Shared by bsf_make_bag and
// bsf_import.
#pragma once

#include <ros/time.h>

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "bsf_vpr/core/types.h"

namespace rosbag {
class Bag;
}

namespace bsf_vpr {
namespace tools {

// The topics of a query bag (launch/replay.launch records the last two with the results).
constexpr char kQueryImageTopic[] = "/camera/image_raw";     // sensor_msgs/Image (bgr8)
constexpr char kQueryDescriptorTopic[] = "/vpr/descriptor";  // bsf_vpr/Descriptor
constexpr char kGroundTruthTopic[] = "/vpr/ground_truth";    // bsf_vpr/QueryGroundTruth
constexpr char kQueryPoseTopic[] = "/vpr/query_pose";        // geometry_msgs/PoseStamped

// Writes a bag to `path`.tmp and renames it to `path` on Commit(); a writer destroyed before
// Commit() removes its temporary file, so that a failure never leaves half a bag behind.
// Every message's bag time is its header stamp. Not thread-safe; not copyable.
class QueryBagWriter {
 public:
  // Creates the folders of `path` and opens `path`.tmp. Queries go to `query_topic`, poses
  // are in frame `pose_frame`. Throws std::runtime_error naming the file.
  QueryBagWriter(std::string path, std::string query_topic, std::string pose_frame = "map");
  ~QueryBagWriter();
  QueryBagWriter(const QueryBagWriter&) = delete;
  QueryBagWriter& operator=(const QueryBagWriter&) = delete;

  // One query: an 8-bit BGR image as sensor_msgs/Image (encoding bgr8), or `dimension`
  // floats as bsf_vpr/Descriptor (`descriptor_type` may be empty). Frame id "camera".
  void WriteImage(const ros::Time& stamp, const cv::Mat& bgr8);
  void WriteDescriptor(const ros::Time& stamp, const float* values, int dimension,
                       const std::string& descriptor_type = "");
  // The correct places of query `query_index` (0-based, in bag order), on kGroundTruthTopic.
  void WriteGroundTruth(const ros::Time& stamp, int query_index,
                        const std::vector<int>& correct_places);
  // The query's pose (metres, yaw in radians about z) on kQueryPoseTopic in pose_frame.
  void WritePose(const ros::Time& stamp, const PlacePose& pose);

  // Closes the bag, still under its temporary name (so that several outputs can be
  // completed before any is put in place). Throws std::runtime_error naming the file.
  void Close();
  // Closes the bag if open and renames it to `path`. Throws std::runtime_error naming it.
  void Commit();

  const std::string& path() const { return path_; }
  const std::string& query_topic() const { return query_topic_; }

 private:
  std::string path_, tmp_, query_topic_, pose_frame_;
  std::unique_ptr<rosbag::Bag> bag_;
  bool committed_ = false;
};

}  // namespace tools
}  // namespace bsf_vpr
