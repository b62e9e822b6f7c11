#include "src/ros/fusion/fusion_params.h"

#include <ros/param.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>
#include <optional>
#include <stdexcept>

namespace bsf_vpr {

namespace {

// The rviz view's options of the publishing table (BeliefViewOptions).
void AddViewParams(OptionTable<RecognitionPublisherOptions>* table) {
  (*table)
      .Add(
          "marker_spacing_m", [](auto& p) -> auto& { return p.view.marker_spacing_m; },
          "distance between places drawn in rviz when they do not all have poses; 0: the "
          "places are spread over marker_view_size_m",
          "m", AtLeast(0))
      .Add(
          "marker_view_size_m", [](auto& p) -> auto& { return p.view.view_size_m; },
          "size of the area the rviz view shows (rviz/bsf_vpr.rviz frames 100 m): markers "
          "are sized for the smaller of it and the route's extent, and a route larger than "
          "it is drawn shrunk to fit it (the legend says how much)",
          "m", Above(0))
      .Add(
          "marker_log_scale", [](auto& p) -> auto& { return p.view.log_scale; },
          "belief bars and the match image's plot show log10 of the posterior over 4 "
          "decades instead of the posterior")
      .Add(
          "match_image_max_file_mb",
          [](auto& p) -> auto& { return p.view.match_image_max_file_mb; },
          "the match image's reference image: a larger file is not read (a warning names "
          "the set and row, and the image shows a placeholder)",
          "MiB", Above(0))
      .Add(
          "match_image_max_megapixels",
          [](auto& p) -> auto& { return p.view.match_image_max_megapixels; },
          "the match image's reference image: one whose header claims more pixels (width "
          "x height) is not decoded (a small PNG can claim gigapixels); only PNG, JPEG "
          "and BMP are shown, the formats whose size is read before decoding",
          "million pixels", Above(0))
      .Add(
          "view_frame", [](auto& p) -> auto& { return p.view.view_frame; },
          "tf child of map_frame broadcast with the markers, which rviz/bsf_vpr.rviz "
          "follows: at the centre of the route as drawn")
      .Add(
          "ground_truth_topic", [](auto& p) -> auto& { return p.ground_truth_topic; },
          "bsf_vpr/QueryGroundTruth of the queries (the bags of bsf_make_bag and bsf_import "
          "carry it): rviz and the match image mark the true places; \"\": none");
}

}  // namespace

const OptionTable<RecognitionPublisherOptions>& PublishingParamsTable() {
  static const OptionTable<RecognitionPublisherOptions> kTable = [] {
    OptionTable<RecognitionPublisherOptions> t;
    t.Add(
         "belief_top_k", [](auto& p) -> auto& { return p.belief_top_k; },
         "places in each Belief message: 0 = all N places, else the K best", "places", AtLeast(0))
        .Add(
            "map_frame", [](auto& p) -> auto& { return p.map_frame; },
            "frame of the place poses, parent of place_frame")
        .Add(
            "place_frame", [](auto& p) -> auto& { return p.place_frame; },
            "tf child frame broadcast at an accepted match that has a pose")
        .Add(
            "publish_tf", [](auto& p) -> auto& { return p.publish_tf; },
            "broadcast map_frame -> place_frame on accepted matches")
        .Add(
            "publish_pose", [](auto& p) -> auto& { return p.publish_pose; },
            "publish the robot's pose on pose (geometry_msgs/PoseWithCovarianceStamped in "
            "map_frame, stamped as the query) for accepted matches whose places have poses: "
            "the posterior's mean over the match's neighbourhood, with the covariance of "
            "where the robot is given that the neighbourhood holds it (the chance it does "
            "not is the match's wrong_probability), for robot_localization (pose0) or amcl "
            "(initialpose)")
        .Add(
            "pose_neighbourhood_m", [](auto& p) -> auto& { return p.pose_neighbourhood_m; },
            "the match's neighbourhood that pose is the mean of: the places within this "
            "distance of the match; 0: twice the median place spacing",
            "m", AtLeast(0))
        .Add(
            "pose_min_std_m", [](auto& p) -> auto& { return p.pose_min_std_m; },
            "floor of that pose's standard deviation in x and y (a place stands for a "
            "stretch of route one spacing long); 0: the median place spacing / sqrt(12)",
            "m", AtLeast(0))
        .Add(
            "publish_queue_size", [](auto& p) -> auto& { return p.publish_queue_size; },
            "messages the belief, match and pose publishers each hold for a subscriber "
            "that has not taken them yet, before roscpp drops the oldest unseen (a gap in "
            "header.seq): 100 is 10 s at 10 Hz, 3 s at 30 Hz",
            "messages", Between(1, 100000))
        .Add(
            "localization_timeout", [](auto& p) -> auto& { return p.localization_timeout_s; },
            "no belief for this long (or for 3 of the recent intervals between beliefs, if "
            "longer: a slow camera) after one was published, and localization says not "
            "localised, with the reason (a covered camera whose images the ingest drops, "
            "descriptors refused, no input)",
            "s", Above(0))
        .Add(
            "localization_hold_s", [](auto& p) -> auto& { return p.localization_hold_s; },
            "after an accepted match, localization stays localised (at that place, with "
            "held_s) through beliefs that accept none for up to this long by the queries' "
            "stamps, until one says off the map (P(off) > 0.5) or beliefs stop "
            "(localization_timeout): a frame between places or a passing truck does not "
            "make the robot lost; 0: localised exactly when a belief is accepted",
            "s", AtLeast(0));
    AddViewParams(&t);
    return t;
  }();
  return kTable;
}

const OptionTable<OdometryParams>& OdometryParamsTable() {
  static const OptionTable<OdometryParams> kTable =
      OptionTable<OdometryParams>()
          .AddChoice(
              "odometry_source", [](auto& p) -> auto& { return p.odometry_source; },
              "progress between queries for +filter methods: none (the "
              "filter_step_mean_places), topic (nav_msgs/Odometry on odometry_topic) "
              "or tf (odom_frame -> base_frame)",
              OdometrySourceNames())
          .Add(
              "odometry_topic", [](auto& p) -> auto& { return p.odometry_topic; },
              "nav_msgs/Odometry topic when odometry_source is topic")
          .Add(
              "odom_frame", [](auto& p) -> auto& { return p.odom_frame; },
              "odometry frame when odometry_source is tf")
          .Add(
              "base_frame", [](auto& p) -> auto& { return p.base_frame; },
              "robot frame when odometry_source is tf")
          .Add(
              "place_spacing_m", [](auto& p) -> auto& { return p.place_spacing_m; },
              "distance between places along the route: turns odometry into a step in places "
              "(+filter), and spaces the places a recording by pose makes where the map has "
              "none; 0: the median spacing of the loaded place poses (1 m without any)",
              "m", AtLeast(0))
          .Add(
              "odometry_timeout_s", [](auto& p) -> auto& { return p.odometry_timeout_s; },
              "odometry last heard longer ago than this is stale: a query then gets the "
              "filter's step distribution (filter_step_mean_places), as without odometry, and "
              "diagnostics warn; a non-finite odometry position is refused (counted) and never "
              "taken as the latest. Several odometry periods (odometry is usually 20-100 Hz)",
              "s", Above(0));
  return kTable;
}

const OptionTable<RecordingParams>& RecordingParamsTable() {
  static const OptionTable<RecordingParams> kTable =
      OptionTable<RecordingParams>()
          .AddChoice(
              "pose_source", [](auto& p) -> auto& { return p.pose_source; },
              "where the robot's pose in map_frame comes from when recording by pose: "
              "tf (map_frame -> base_frame), topic (pose_topic) or none",
              PoseSourceNames())
          .Add(
              "pose_topic", [](auto& p) -> auto& { return p.pose_topic; },
              "the robot's pose in map_frame when pose_source is topic: nav_msgs/Odometry, "
              "geometry_msgs/PoseStamped or geometry_msgs/PoseWithCovarianceStamped (the "
              "type is taken from the publisher)")
          .Add(
              "pose_wait_s", [](auto& p) -> auto& { return p.pose_wait_s; },
              "how long a descriptor waits for the robot's pose at its stamp (tf, or the "
              "pose_topic message after it, interpolated): a camera image is usually newer "
              "than the last pose; enough for a 10 Hz pose source by default",
              "s", Between(0, 10))
          .Include(PlaceIndexOptionsTable(), [](auto& p) -> auto& { return p.places; },
                   {"place_spacing_m"})
          .Add(
              "recording_max_descriptors",
              [](auto& p) -> auto& { return p.recording_max_descriptors; },
              "the most descriptors a recording holds (about 1.9 h at 30 Hz by default): a "
              "warning at 90%, then descriptors are refused (counted) until stop_recording",
              "descriptors", AtLeast(1))
          .Add(
              "recording_max_megabytes", [](auto& p) -> auto& { return p.recording_max_megabytes; },
              "the most memory a recording's descriptors and images take (2048-d descriptors "
              "at 30 Hz: about 0.9 GB an hour): a warning at 90%, then descriptors are refused "
              "(counted) until stop_recording",
              "MB", AtLeast(1));
  return kTable;
}

const OptionTable<FusionParams>& FusionParamsTable() {
  static const OptionTable<FusionParams> kTable =
      OptionTable<FusionParams>()
          .Include(MapParamsTable(), AsBase<MapParams>())
          .Include(
              RecognizerOptionsTable(), [](auto& p) -> auto& { return p.recognizer; })
          .Include(PublishingParamsTable(), AsBase<RecognitionPublisherOptions>())
          .Include(OdometryParamsTable(), AsBase<OdometryParams>())
          .Include(RecordingParamsTable(), AsBase<RecordingParams>())
          .Include(QueueParamsTable(), AsBase<QueueParams>())
          .Include(ShardingParamsTable(), AsBase<ShardingParams>());
  return kTable;
}

FusionParams LoadFusionParams(RosParamSource& source) {
  for (const char* retired : {"carry_prior", "prior_uniform_fraction"}) {
    if (source.Has(retired)) {
      throw std::invalid_argument(
          std::string("parameter ") + retired +
          " was removed: the +filter suffix carries the belief between queries (e.g. method: "
          "bsf+filter, with filter_step_mean_places 0 for the former carry_prior)");
    }
  }
  FusionParams p = LoadOptions(FusionParamsTable(), source);
  p.reference_sets = LoadReferenceSetEntries(source);
  p.shards = LoadShardNames(source);
  source.RefuseUnread();
  p.recognizer.metric = p.distance.value_or(DistanceMetric::kEuclidean);
  p.recognizer.Validate();
  if (p.map_frame.empty() || p.place_frame.empty() || p.view.view_frame.empty()) {
    throw std::invalid_argument("map_frame, place_frame and view_frame must not be empty");
  }
  p.view.map_frame = p.map_frame;
  return p;
}

FusionParams LoadFusionParams(const ros::NodeHandle& pnh) {
  RosParamSource source = RosParamSource::FromNodeHandle(pnh);
  return LoadFusionParams(source);
}

}  // namespace bsf_vpr
