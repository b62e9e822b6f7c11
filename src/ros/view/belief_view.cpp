#include "src/ros/view/belief_view.h"

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/console.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <utility>

#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/image_problem.h"
#include "src/ros/view/match_image.h"

namespace bsf_vpr {
namespace {

constexpr size_t kImagesKept = 30;   // query images waiting for their belief
constexpr size_t kTruthsKept = 300;  // ground truth waiting for its belief
// Reference images kept decoded, reduced to a few times the panel's height (the panel is
// smaller; a 4000 x 3000 photo is 36 MB decoded); a file replaced on disk is read again
// after kReferenceImageAge.
constexpr size_t kReferenceImagesKept = 8;
const int kReferenceImageMaxRows = 4 * MatchImageOptions().panel_height_px;
constexpr std::chrono::seconds kReferenceImageAge(30);

}  // namespace

BeliefView::BeliefView(ros::NodeHandle& nh, ros::NodeHandle& pnh, BeliefViewOptions options,
                       const std::string& ground_truth_topic, const DataDirectory* data_dir)
    : options_(std::move(options)),
      data_dir_(data_dir),
      nh_(nh),
      it_(nh),
      reference_images_(kReferenceImagesKept, kReferenceImageMaxRows, kReferenceImageAge) {
  marker_pub_ = nh.advertise<visualization_msgs::MarkerArray>(names::kBeliefMarkersTopic, 1);
  image_transport::ImageTransport private_it(pnh);
  const image_transport::SubscriberStatusCallback changed =
      [this](const image_transport::SingleSubscriberPublisher&) { OnMatchImageSubscribers(); };
  match_image_pub_ = private_it.advertise(names::kMatchImageTopic, 1, changed, changed);
  if (!ground_truth_topic.empty()) {
    truth_sub_ = nh.subscribe(ground_truth_topic, 100, &BeliefView::OnGroundTruth, this);
  }
}

void BeliefView::OnMatchImageSubscribers() {
  MutexLock lock(&mutex_);
  if (match_image_pub_.getNumSubscribers() > 0 && !image_sub_) {
    image_sub_ = it_.subscribe(names::kImageTopic, 5, &BeliefView::OnImage, this);
  } else if (match_image_pub_.getNumSubscribers() == 0 && image_sub_) {
    image_sub_.shutdown();
    images_.clear();
  }
}

void BeliefView::OnImage(const sensor_msgs::ImageConstPtr& image) {
  MutexLock lock(&mutex_);
  images_.push_back(image);
  if (images_.size() > kImagesKept) images_.pop_front();
  if (pending_ && pending_->header.stamp == image->header.stamp) {
    pending_->content.query = ToBgr(image, &pending_->content.query_note);
    PublishPending();
  }
}

cv::Mat BeliefView::ToBgr(const sensor_msgs::ImageConstPtr& image, std::string* note) {
  const std::string problem = ImageProblem(*image);
  if (!problem.empty()) {
    *note = "query image not shown: " + problem;
    return cv::Mat();
  }
  try {
    *note = "query";
    return cv_bridge::toCvShare(image, "bgr8")->image.clone();
  } catch (const std::exception& e) {
    *note = "query image not shown: " + std::string(e.what());
    return cv::Mat();
  }
}

void BeliefView::PublishPending() {
  try {
    cv_bridge::CvImage out(pending_->header, "bgr8",
                           RenderMatchImage(pending_->content, pending_->options));
    match_image_pub_.publish(out.toImageMsg());
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE(5.0, "bsf_vpr: match image not published: %s", e.what());
  }
  pending_.reset();
}

void BeliefView::OnGroundTruth(const QueryGroundTruth::ConstPtr& truth) {
  MutexLock lock(&mutex_);
  truths_.emplace_back(truth->header.stamp, truth->correct_places);
  if (truths_.size() > kTruthsKept) truths_.pop_front();
  if (!drawn_has_truth_ && truth->header.stamp == drawn_header_.stamp) {
    AddLateTruth(truth->correct_places);
  }
}

void BeliefView::AddLateTruth(const std::vector<int>& places) {
  drawn_has_truth_ = true;
  if (auto marker = TruePlacesMarker(drawn_route_, places, drawn_header_, options_)) {
    visualization_msgs::MarkerArray late;
    late.markers.push_back(*marker);
    marker_pub_.publish(late);
  }
}

const std::vector<int>* BeliefView::FindTruth(const ros::Time& stamp) const {
  for (auto it = truths_.rbegin(); it != truths_.rend(); ++it) {
    if (it->first == stamp) return &it->second;
  }
  return nullptr;
}

std::vector<int> BeliefView::TruePlaces(const ros::Time& stamp) {
  MutexLock lock(&mutex_);
  const std::vector<int>* found = FindTruth(stamp);
  return found ? *found : std::vector<int>();
}

sensor_msgs::ImageConstPtr BeliefView::QueryImage(const ros::Time& stamp) const {
  for (auto it = images_.rbegin(); it != images_.rend(); ++it) {
    if ((*it)->header.stamp == stamp) return *it;
  }
  return nullptr;
}

cv::Mat BeliefView::ReferenceImage(const Belief& belief, const Recognition& r,
                                   const PlaceLayout& layout, std::string* note) {
  if (r.closest_set < 0) {
    *note = "no set the method used covers place " + std::to_string(belief.match);
    return cv::Mat();
  }
  const SetLayout& set = layout.set(r.closest_set);
  const auto& ids = set.place_ids;
  const auto row = std::find(ids.begin(), ids.end(), belief.match) - ids.begin();
  if (row == static_cast<long>(ids.size())) {
    *note = "set '" + set.name + "' does not cover place " + std::to_string(belief.match);
    return cv::Mat();
  }
  if (set.image_files.empty()) {
    *note = "set '" + set.name +
            "' has no images: recorded without images, or its YAML names none (images:; "
            "by service only below the data directory)";
    return cv::Mat();
  }
  ReferenceImageLimits limits;
  limits.max_bytes = static_cast<uint64_t>(options_.match_image_max_file_mb * (1 << 20));
  limits.max_pixels = static_cast<uint64_t>(options_.match_image_max_megapixels * 1e6);
  const auto load = [&]() {
    // Throws naming the set, the row and the file when unreadable or too large.
    const std::string bytes =
        ReadReferenceImage(set, static_cast<int>(row), data_dir_, limits.max_bytes);
    try {
      return DecodeReferenceImage(bytes, limits);
    } catch (const std::exception& e) {
      throw std::runtime_error(
          "reference set " + QuotedForMessage(set.name) + " row " + std::to_string(row) + " (" +
          QuotedForMessage(set.image_files[static_cast<size_t>(row)]) + "): " + e.what());
    }
  };
  // Keyed by file; a row recorded without an image (an empty entry) by its row, so that its
  // refusal names that row.
  const std::string& file = set.image_files[static_cast<size_t>(row)];
  const std::string key = set.images + "/" + (file.empty() ? "#" + std::to_string(row) : file);
  const ReferenceImageCache::Entry entry =
      reference_images_.Get(key, load, std::chrono::steady_clock::now());
  if (!entry.error.empty()) {
    ROS_WARN_THROTTLE(5.0,
                      "bsf_vpr: match image shown without its reference image: %s (limits: "
                      "parameters match_image_max_file_mb, match_image_max_megapixels)",
                      entry.error.c_str());
    *note = "reference image not shown: " + entry.error;
    return cv::Mat();
  }
  *note = set.name + ", place " + std::to_string(belief.match);
  return entry.image;
}

void BeliefView::PublishMatchImage(const Belief& belief, const Recognition& r,
                                   const PlaceLayout& layout, const std::vector<int>& truth,
                                   bool probabilistic) {
  PendingImage next;
  next.header = belief.header;
  MatchImageContent& content = next.content;
  content.reference = ReferenceImage(belief, r, layout, &content.reference_note);
  content.label_lines = BeliefLabelLines(belief, probabilistic);
  content.accepted = belief.accepted;
  content.num_places = belief.num_places;
  content.place_ids = belief.place_ids;
  content.posterior = belief.posterior;
  content.match = belief.match;
  content.true_places = truth;
  next.options.log_scale = options_.log_scale;
  MutexLock lock(&mutex_);
  if (pending_) {  // its image never came: shown without
    pending_->content.query_note =
        "no query image with this stamp on " + nh_.resolveName(names::kImageTopic);
    PublishPending();
  }
  pending_ = std::move(next);
  if (const sensor_msgs::ImageConstPtr image = QueryImage(belief.header.stamp)) {
    pending_->content.query = ToBgr(image, &pending_->content.query_note);
    PublishPending();
  } else if (images_.empty()) {  // no camera: do not wait for one
    pending_->content.query_note = "no query image on " + nh_.resolveName(names::kImageTopic);
    PublishPending();
  }
  // Else the image is still on its way (the descriptor can overtake it): OnImage publishes.
}

void BeliefView::Show(const Belief& belief, const Recognition& r, const PlaceLayout& layout,
                      const PlaceDecider& decider) {
  const bool markers = marker_pub_.getNumSubscribers() > 0;
  const bool image = match_image_pub_.getNumSubscribers() > 0;
  if (!markers && !image) return;
  const std::vector<int> truth = TruePlaces(belief.header.stamp);
  const Method& method = decider.method();
  const bool probabilistic = method.IsBayesian() || method.sequence;  // confidence: log-odds
  if (markers) {
    RouteDrawing route = MakeRouteDrawing(layout, options_);
    geometry_msgs::TransformStamped view;
    view.header.stamp = belief.header.stamp.isZero() ? ros::Time::now() : belief.header.stamp;
    view.header.frame_id = options_.map_frame;
    view.child_frame_id = options_.view_frame;
    const Eigen::Vector3d focus = ViewFocus(route);
    view.transform.translation.x = focus.x();
    view.transform.translation.y = focus.y();
    view.transform.translation.z = focus.z();
    view.transform.rotation.w = 1;
    tf_.sendTransform(view);
    marker_pub_.publish(MakeBeliefMarkers(route, belief, truth, probabilistic, options_));
    MutexLock lock(&mutex_);
    drawn_route_ = std::move(route);
    drawn_header_ = belief.header;
    drawn_has_truth_ = !truth.empty();
    if (!drawn_has_truth_) {  // arrived since TruePlaces() looked?
      if (const std::vector<int>* late = FindTruth(belief.header.stamp)) AddLateTruth(*late);
    }
  }
  if (image) {
    PublishMatchImage(belief, r, layout, truth, probabilistic);
  }
}

}  // namespace bsf_vpr
