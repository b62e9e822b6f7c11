#include "recognition_publisher.h"

#include <utility>

#include "bsf_vpr/ros/names.h"
#include "conversions.h"

namespace bsf_vpr {

RecognitionPublisher::RecognitionPublisher(ros::NodeHandle& nh, ros::NodeHandle& pnh,
                                           RecognitionPublisherOptions options,
                                           const DataDirectory* data_dir)
    : options_(std::move(options)),
      view_(nh, pnh, options_.view, options_.ground_truth_topic, data_dir) {
  belief_pub_ = nh.advertise<Belief>(names::kBeliefTopic, 10);
  match_pub_ = nh.advertise<Match>(names::kMatchTopic, 10);
  if (options_.publish_tf) tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
}

void RecognitionPublisher::Publish(const std_msgs::Header& header, const Recognition& r,
                                   const PlaceRecognizer& recognizer, double seconds) {
  auto belief = boost::make_shared<Belief>();
  belief->header = header;
  ToBeliefMsg(r, recognizer, options_.belief_top_k, belief.get());
  belief->processing_time = seconds;
  belief_pub_.publish(belief);
  if (r.belief.accepted) {
    auto match = boost::make_shared<Match>();
    match->header = header;
    match->header.frame_id = options_.map_frame;
    ToMatchMsg(r, recognizer.map(), match.get());
    match_pub_.publish(match);
    if (tf_ && match->has_pose) {
      const ros::Time stamp = header.stamp.isZero() ? ros::Time::now() : header.stamp;
      tf_->sendTransform(ToPlaceTransformMsg(*match, stamp, options_.place_frame));
    }
  }
  view_.Show(*belief, r, recognizer);
}

}  // namespace bsf_vpr
