#include "src/ros/fusion/recognition_publisher.h"

#include <bsf_vpr/Localization.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/console.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/pose_estimate.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"

namespace bsf_vpr {

RecognitionPublisher::RecognitionPublisher(ros::NodeHandle& nh, ros::NodeHandle& pnh,
                                           RecognitionPublisherOptions options,
                                           const DataDirectory* data_dir)
    : options_(std::move(options)),
      view_(nh, pnh, options_.view, options_.ground_truth_topic, data_dir) {
  const auto queue = static_cast<uint32_t>(std::max(1, options_.publish_queue_size));
  belief_pub_ = nh.advertise<Belief>(names::kBeliefTopic, queue);
  match_pub_ = nh.advertise<Match>(names::kMatchTopic, queue);
  if (options_.publish_pose) {
    pose_pub_ = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>(names::kPoseTopic, queue);
  }
  if (options_.publish_tf) tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  localization_pub_ = nh.advertise<Localization>(names::kLocalizationTopic, queue, true);
}

namespace {

// Why a belief is not localised ("" when it is).
std::string NotLocalizedReason(const PlaceBelief& b) {
  if (b.accepted) return "";
  char out[96];
  if (b.off_map_probability > 0.5) {
    std::snprintf(out, sizeof out, "off the map (P %.2f)", b.off_map_probability);
  } else {
    std::snprintf(out, sizeof out, "no match accepted (confidence %.2f)", b.confidence);
  }
  return out;
}

}  // namespace

void RecognitionPublisher::PublishLocalization(const std_msgs::Header& header, const PlaceBelief& b,
                                               int num_places) {
  const ros::Time stamp = header.stamp.isZero() ? ros::Time::now() : header.stamp;
  // Held: localised on a match accepted at most localization_hold_s before, through beliefs
  // that accept none but do not say the robot is off the map (one frame between places, a
  // passing truck, a blurred frame is no reason to tell a robot it is lost). The previous
  // belief was localised (an off-map one ends the hold), no silence came between
  // (CheckStale), and the place is still one of the map's (the sets may have changed).
  const bool held = options_.localization_hold_s > 0 && !b.accepted && localized_.value_or(false) &&
                    stale_.empty() && !last_accepted_.isZero() && stamp >= last_accepted_ &&
                    (stamp - last_accepted_).toSec() <= options_.localization_hold_s &&
                    !(b.off_map_probability > 0.5) && localized_place_ >= 0 &&
                    localized_place_ < num_places;
  const bool localized = b.accepted || held;
  if (!localized_ || *localized_ != localized || stamp < localized_since_ || !stale_.empty()) {
    localized_ = localized;
    localized_since_ = stamp;
  }
  stale_.clear();
  last_stamp_ = stamp;
  if (b.accepted) last_accepted_ = stamp;
  if (!held) localized_place_ = b.accepted ? b.match : -1;
  off_map_probability_ = b.off_map_probability;
  auto msg = boost::make_shared<Localization>();
  msg->header = header;
  msg->localized = localized;
  msg->place = localized_place_;
  msg->off_map_probability = b.off_map_probability;
  msg->since_s = (stamp - localized_since_).toSec();
  msg->held_s = held ? (stamp - last_accepted_).toSec() : 0.0;
  msg->reason = localized ? "" : NotLocalizedReason(b);
  localization_pub_.publish(msg);
}

std::string RecognitionPublisher::CheckStale(const ros::Time& now, const std::string& why) {
  if (last_belief_time_.isZero()) return "";
  const double silent = (now - last_belief_time_).toSec();
  double timeout = options_.localization_timeout_s;
  if (intervals_.size() >= 5) {
    // A slow camera: no belief for 3 of its usual intervals.
    std::vector<double> sorted = intervals_;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    timeout = std::max(timeout, 3 * sorted[sorted.size() / 2]);
  }
  if (!(silent > timeout)) return "";
  char head[64];
  std::snprintf(head, sizeof head, "no belief for %.1f s: ", silent);
  const bool first = stale_.empty();
  stale_ = head + why;
  // Published when the robot stops being localised and again when the reason changes (the
  // latched message says the latest), not for the time alone.
  if (!first && why == stale_why_) return stale_;
  stale_why_ = why;
  const bool was_localized = localized_.value_or(false) && first;
  if (first) {
    localized_ = false;
    if (was_localized) localized_since_ = now;
    localized_place_ = -1;
    last_accepted_ = ros::Time();  // a new belief after the silence is not held
  }
  last_stamp_ = now;
  auto msg = boost::make_shared<Localization>();
  msg->header.stamp = now;
  msg->header.frame_id = options_.map_frame;
  msg->localized = false;
  msg->place = -1;
  msg->off_map_probability = off_map_probability_;
  msg->since_s = (now - localized_since_).toSec();
  msg->reason = stale_;
  localization_pub_.publish(msg);
  if (was_localized) ROS_WARN("bsf_vpr: not localised: %s", stale_.c_str());
  return stale_;
}

void RecognitionPublisher::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  if (!localized_) {
    status.add("localized", "no belief yet");
    return;
  }
  const double since = (last_stamp_ - localized_since_).toSec();
  if (!stale_.empty()) {
    status.addf("localized", "no, for %.1f s (%s)", since, stale_.c_str());
  } else if (*localized_) {
    status.addf("localized", "yes, at place %d, for %.1f s", localized_place_, since);
  } else {
    status.addf("localized", "no, for %.1f s (P(off the map) %.3f)", since, off_map_probability_);
  }
}

void RecognitionPublisher::Publish(const std_msgs::Header& header, const Recognition& r,
                                   const PlaceLayout& layout, const PlaceDecider& decider,
                                   double seconds) {
  auto belief = boost::make_shared<Belief>();
  belief->header = header;
  belief->header.seq = static_cast<uint32_t>(beliefs_++);
  ToBeliefMsg(r, layout, decider, options_.belief_top_k, belief.get());
  belief->processing_time = seconds;
  belief_pub_.publish(belief);
  const ros::Time now = ros::Time::now();
  if (!last_belief_time_.isZero() && now > last_belief_time_) {
    if (intervals_.size() >= 20) intervals_.erase(intervals_.begin());
    intervals_.push_back((now - last_belief_time_).toSec());
  }
  last_belief_time_ = now;
  PublishLocalization(header, r.belief, layout.num_places());
  if (r.belief.accepted) {
    auto match = boost::make_shared<Match>();
    match->header = header;
    match->header.frame_id = options_.map_frame;
    match->header.seq = static_cast<uint32_t>(matches_++);
    const bool pose_ok = ToMatchMsg(r, layout, match.get());
    if (!pose_ok) {
      ROS_ERROR_THROTTLE(1.0,
                         "bsf_vpr: place %d's pose %s: its match is published without a pose, "
                         "and neither tf nor the robot's pose is sent",
                         r.belief.match, PoseProblem(*layout.PoseOf(r.belief.match)).c_str());
    }
    const std::optional<PoseEstimate> pose =
        pose_ok ? EstimateMatchPose(r, layout, decider) : std::nullopt;
    match->wrong_probability =
        pose ? pose->wrong_probability : std::numeric_limits<double>::quiet_NaN();
    match_pub_.publish(match);
    if (tf_ && match->has_pose) {
      const ros::Time stamp = header.stamp.isZero() ? ros::Time::now() : header.stamp;
      tf_->sendTransform(ToPlaceTransformMsg(*match, stamp, options_.place_frame));
    }
    if (options_.publish_pose && pose) PublishPose(header, *pose);
  }
  view_.Show(*belief, r, layout, decider);
}

std::optional<PoseEstimate> RecognitionPublisher::EstimateMatchPose(
    const Recognition& r, const PlaceLayout& layout, const PlaceDecider& decider) const {
  PoseEstimateOptions o;
  const double spacing = layout.MedianPlaceSpacing().value_or(0.0);
  // A place stands for one spacing of route: the robot lies uniformly within it.
  o.min_std_m = options_.pose_min_std_m > 0 ? options_.pose_min_std_m : spacing / std::sqrt(12.0);
  if (!(o.min_std_m > 0)) o.min_std_m = 1.0;
  o.neighbourhood_m =
      options_.pose_neighbourhood_m > 0 ? options_.pose_neighbourhood_m : 2 * spacing;
  const Method& method = decider.method();
  // A +seq match is the sequence's end, and a distance method has no posterior: the pose is
  // the match's, with the posterior's spread about it.
  const bool centred = method.sequence || !method.IsBayesian();
  return EstimatePose(r.belief, layout.place_poses(), centred, o);  // nullopt: nothing finite
}

void RecognitionPublisher::PublishPose(const std_msgs::Header& header, const PoseEstimate& e) {
  auto msg = boost::make_shared<geometry_msgs::PoseWithCovarianceStamped>();
  msg->header = header;
  msg->header.frame_id = options_.map_frame;
  msg->header.seq = static_cast<uint32_t>(poses_++);
  ToPoseWithCovarianceMsg(e, &msg->pose);
  pose_pub_.publish(msg);
}

}  // namespace bsf_vpr
