// What the fusion node publishes for each recognised descriptor: the belief and whether the
// robot is localised (always; the latter latched); the match when accepted, with the tf frame
// map_frame -> place_frame at the matched place when the place has a pose, and the robot's pose
// with its covariance (pose_estimate.h) for a localiser to fuse; and what rviz shows of it
// (belief_view.h: markers, view frame, match image) while someone listens. Topics are names.h's,
// advertised in the namespace of the node handle given (the match image in the private one).
// Nothing non-finite is published: a matched place whose pose ToMatchPose refuses gets its match
// without a pose, no tf and no robot's pose, and a throttled error.
//
// Each of the belief, match and pose topics numbers its messages itself: header.seq is 0, 1,
// 2, ... per topic (the stamp and frame are the query's), so a subscriber tells a message
// lost on the way (a full queue, publish_queue_size) from a gap in it. roscpp numbers what
// it sends over TCP the same way; a nodelet in the same manager gets this number too, where
// it would otherwise see the descriptor's. What the publisher's own queue drops cannot be
// seen from here (roscpp drops the oldest silently): published() counts what was handed on.
//
// Not thread-safe: the fusion node holds its lock.
#pragma once

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <ros/node_handle.h>
#include <ros/publisher.h>
#include <std_msgs/Header.h>
#include <tf2_ros/transform_broadcaster.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/place_decider.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/pose_estimate.h"
#include "bsf_vpr/io/data_directory.h"
#include "src/ros/view/belief_view.h"

namespace bsf_vpr {

// The fusion parameters of the same names (fusion_params.h, PublishingParamsTable(), which
// documents them); fixed once the node has started.
struct RecognitionPublisherOptions {
  std::string map_frame = "map";          // frame of the match, the markers and the tf parent
  std::string place_frame = "vpr_place";  // tf child frame at the matched place
  bool publish_tf = true;
  int belief_top_k = 0;                                  // 0: the belief lists every place
  BeliefViewOptions view;                                // its map_frame is map_frame
  std::string ground_truth_topic = "/vpr/ground_truth";  // "": none
  bool publish_pose = true;  // the robot's pose from accepted matches, on names::kPoseTopic
  // The match's neighbourhood the pose is the mean of; 0: twice the median place spacing.
  double pose_neighbourhood_m = 0;
  // Floor of the pose's standard deviation in x and y; 0: the place spacing / sqrt(12).
  double pose_min_std_m = 0;
  // Messages each of the belief, match and pose publishers holds per subscriber before
  // roscpp drops the oldest.
  int publish_queue_size = 100;
  // No belief for this long (or for 3 intervals of the recent descriptors, if longer): the
  // robot is not localised (CheckStale).
  double localization_timeout_s = 1.0;
  // After an accepted match the robot stays localised (at that place) through beliefs that
  // accept none for up to this long, by the queries' stamps, until one says it is off the
  // map (P(off) > 0.5) or beliefs stop (CheckStale); 0: localised exactly when the belief is
  // accepted.
  double localization_hold_s = 1.0;
};

class RecognitionPublisher {
 public:
  // Advertises the topics on `nh` (and the match image on `pnh`). `data_dir` (may be null)
  // is where reference images below it are read through; it must outlive the publisher.
  RecognitionPublisher(ros::NodeHandle& nh, ros::NodeHandle& pnh,
                       RecognitionPublisherOptions options, const DataDirectory* data_dir);

  // Publishes what `r` found for the descriptor whose header is `header`: `decider` found it
  // on `layout` (method, gamma, sets and place poses); `seconds` the time spent.
  void Publish(const std_msgs::Header& header, const Recognition& r, const PlaceLayout& layout,
               const PlaceDecider& decider, double seconds);

  // Beliefs published since start (the next belief's header.seq), and matches.
  uint64_t beliefs_published() const { return beliefs_; }
  uint64_t matches_published() const { return matches_; }

  // Whether the robot is localised, since when and at which place ("localized" in the
  // fusion node's diagnostics).
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const;

  // Called periodically: once no belief has been published for the timeout
  // (options.localization_timeout_s, or 3 of the recent intervals between beliefs if longer)
  // after one was, publishes "not localised" with "no belief for X s: " + `why` (what the
  // caller knows of the inputs), again whenever `why` changes, and returns that reason; ""
  // while beliefs come. A new belief publishes its own state again.
  std::string CheckStale(const ros::Time& now, const std::string& why);
  // The reason CheckStale gave, while no belief has come since ("" otherwise).
  const std::string& stale() const { return stale_; }

 private:
  // The pose of an accepted match whose place has one (EstimatePose), nullopt if none.
  std::optional<PoseEstimate> EstimateMatchPose(const Recognition& r, const PlaceLayout& layout,
                                                const PlaceDecider& decider) const;
  void PublishPose(const std_msgs::Header& header, const PoseEstimate& estimate);
  // `num_places`: the map's now (a held place must still be one of them).
  void PublishLocalization(const std_msgs::Header& header, const PlaceBelief& belief,
                           int num_places);

  RecognitionPublisherOptions options_;
  ros::Publisher belief_pub_, match_pub_, pose_pub_, localization_pub_;
  // The localisation state of the last belief: whether localised, since which query stamp,
  // and the last belief's place and P(off).
  std::optional<bool> localized_;
  ros::Time localized_since_, last_stamp_;
  ros::Time last_accepted_;  // the stamp of the last accepted belief (zero: none)
  // When the last belief was published (the node's clock), the recent intervals between
  // beliefs (seconds), and why the robot is not localised without beliefs ("" while they come).
  ros::Time last_belief_time_;
  std::vector<double> intervals_;
  std::string stale_, stale_why_;
  int localized_place_ = -1;
  double off_map_probability_ = 0;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;  // null when publish_tf is false
  uint64_t beliefs_ = 0, matches_ = 0, poses_ = 0;     // published, each its own seq
  BeliefView view_;
};

}  // namespace bsf_vpr
