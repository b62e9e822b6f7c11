// What rviz shows of the fusion node's belief:
// - the markers of belief_markers.h on belief_markers, with the view frame (tf
//   map_frame -> view_frame) that rviz/bsf_vpr.rviz follows;
// - the match image (match_image.h) on ~match_image: the query image beside the matched
//   reference image (when its set names images: in its YAML), annotated, over a plot of the
//   posterior.
// Work is done only while someone listens: markers and the view frame while belief_markers
// has a subscriber, the match image, and the subscription to the query images it needs
// (image, remapped to the camera by bsf_vpr.launch), while ~match_image has one. Ground truth
// (bsf_vpr/QueryGroundTruth on ground_truth_topic, which the bags of bsf_make_bag and
// bsf_import carry) marks the true places of a query whose ground truth arrived before its
// belief.
//
// Show() runs on the caller's thread (the fusion node holds its lock); the subscriptions
// fill caches guarded by a lock of the view's own.
#pragma once

#include <bsf_vpr/Belief.h>
#include <bsf_vpr/QueryGroundTruth.h>
#include <image_transport/image_transport.h>
#include <ros/node_handle.h>
#include <ros/publisher.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/transform_broadcaster.h>

#include <deque>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/core/place_decider.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/io/data_directory.h"
#include "src/ros/view/belief_markers.h"
#include "src/ros/view/match_image.h"
#include "src/ros/view/reference_image.h"

namespace bsf_vpr {

class BeliefView {
 public:
  // Advertises belief_markers on `nh` and match_image on `pnh`; subscribes to
  // ground_truth_topic unless it is "". `data_dir` (may be null) is where reference images
  // below it are read through (DataDirectory rules); it must outlive the view.
  BeliefView(ros::NodeHandle& nh, ros::NodeHandle& pnh, BeliefViewOptions options,
             const std::string& ground_truth_topic, const DataDirectory* data_dir);

  // Draws `belief` (the message published for `r`, found by `decider` on `layout`).
  void Show(const Belief& belief, const Recognition& r, const PlaceLayout& layout,
            const PlaceDecider& decider);

 private:
  void OnImage(const sensor_msgs::ImageConstPtr& image);
  void OnGroundTruth(const QueryGroundTruth::ConstPtr& truth);
  // Subscribes to the query images while ~match_image has subscribers.
  void OnMatchImageSubscribers();
  std::vector<int> TruePlaces(const ros::Time& stamp);
  // The cached ground truth of `stamp`, or null. Caller holds mutex_.
  const std::vector<int>* FindTruth(const ros::Time& stamp) const REQUIRES(mutex_);
  // Adds `places` to the markers last drawn (their ground truth came late). Caller holds
  // mutex_.
  void AddLateTruth(const std::vector<int>& places) REQUIRES(mutex_);
  // The cached query image of `stamp`, or null. Caller holds mutex_.
  sensor_msgs::ImageConstPtr QueryImage(const ros::Time& stamp) const REQUIRES(mutex_);
  // `image` as BGR, or empty with `note` saying why.
  static cv::Mat ToBgr(const sensor_msgs::ImageConstPtr& image, std::string* note);
  // Renders and publishes pending_, then clears it. Caller holds mutex_.
  void PublishPending() REQUIRES(mutex_);
  // The image of the matched place in the set that supplied it, or empty with `note` saying
  // why; `note` names the set and place otherwise. Read within options_' limits, through
  // reference_images_.
  cv::Mat ReferenceImage(const Belief& belief, const Recognition& r, const PlaceLayout& layout,
                         std::string* note);
  // `probabilistic`: the belief's confidence is a log-odds (BeliefLabelLines).
  void PublishMatchImage(const Belief& belief, const Recognition& r, const PlaceLayout& layout,
                         const std::vector<int>& truth, bool probabilistic);

  BeliefViewOptions options_;
  const DataDirectory* data_dir_;
  ros::NodeHandle nh_;
  image_transport::ImageTransport it_;
  ros::Publisher marker_pub_;
  image_transport::Publisher match_image_pub_;
  image_transport::Subscriber image_sub_;
  ros::Subscriber truth_sub_;
  tf2_ros::TransformBroadcaster tf_;
  ReferenceImageCache reference_images_;  // used by Show()'s thread only

  // A match image waiting for its query image (the descriptor may overtake the image it
  // was computed from); published by OnImage, or without the image at the next belief.
  struct PendingImage {
    std_msgs::Header header;
    MatchImageContent content;
    MatchImageOptions options;
  };

  Mutex mutex_;  // guards what follows (filled by the subscriptions' threads)
  std::optional<PendingImage> pending_ GUARDED_BY(mutex_);
  // The latest query images, and ground truth.
  std::deque<sensor_msgs::ImageConstPtr> images_ GUARDED_BY(mutex_);
  std::deque<std::pair<ros::Time, std::vector<int>>> truths_ GUARDED_BY(mutex_);
  // The last markers drawn, so that ground truth arriving after its belief (a bag holds
  // the image before its ground truth) is added to them.
  RouteDrawing drawn_route_ GUARDED_BY(mutex_);
  std_msgs::Header drawn_header_ GUARDED_BY(mutex_);
  bool drawn_has_truth_ GUARDED_BY(mutex_) = true;
};

}  // namespace bsf_vpr
