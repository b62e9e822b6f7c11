// Parameters of the fusion node, read from its private namespace. FusionParamsTable()
// declares each one (name, default, unit, doc, bounds); config/fusion.yaml, cfg/Fusion.cfg
// and docs/options.md are written from it by bsf_options.
#pragma once

#include <ros/node_handle.h>

#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/core/recognizer_options.h"
#include "src/ros/common/param_util.h"
#include "src/ros/fusion/odometry_tracker.h"
#include "src/ros/fusion/recognition_publisher.h"
#include "src/ros/fusion/robot_pose.h"
#include "src/ros/map/map_params.h"
#include "src/ros/view/belief_view_options.h"

namespace bsf_vpr {

// The recognizer's options (RecognizerOptionsTable()).
struct RecognizerParams {
  RecognizerOptions recognizer;
};

// Odometry for +filter methods: none, topic (nav_msgs/Odometry on odometry_topic) or tf
// (odom_frame -> base_frame). The distance travelled between two queries divided by the
// place spacing (place_spacing_m, or the median spacing of the place poses when 0) is the
// filter's step for that query (OdometryParamsTable()).
struct OdometryParams {
  OdometrySource odometry_source = OdometrySource::kNone;
  std::string odometry_topic = "odom";
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";  // also the robot's frame for recording by pose
  double place_spacing_m = 0;
  double odometry_timeout_s = 1.0;  // odometry last heard longer ago is stale
};

// Recording by pose (start_recording places: pose): where the robot's pose in map_frame
// comes from (robot_pose.h: tf map_frame -> base_frame, or a pose topic), how long a
// descriptor waits for it, and how it is associated with the places (places.place_spacing_m
// is set from place_spacing_m) (RecordingParamsTable()).
struct RecordingParams {
  PoseSource pose_source = PoseSource::kTf;
  std::string pose_topic = "odometry/map";
  double pose_wait_s = 0.2;
  PlaceIndexOptions places;
  int recording_max_descriptors = 200000;
  int recording_max_megabytes = 2000;
};

// The fusion node's parameters, part by part, each part with its table: the map's, the
// recognizer's (recognizer.metric is the configured distance, or euclidean), what is
// published (RecognitionPublisherOptions, recognition_publisher.h), odometry, recording by
// pose, the queue and the sharded map. Read once at start; what changes later is the
// decider's (the live options) or the map's (the distance in use).
struct FusionParams : MapParams,
                      RecognizerParams,
                      RecognitionPublisherOptions,
                      OdometryParams,
                      RecordingParams,
                      QueueParams,
                      ShardingParams {};

const OptionTable<RecognitionPublisherOptions>& PublishingParamsTable();
const OptionTable<OdometryParams>& OdometryParamsTable();
const OptionTable<RecordingParams>& RecordingParamsTable();

// The declaration of every parameter (reference_sets, a list of mappings, is read by code
// of its own).
const OptionTable<FusionParams>& FusionParamsTable();

// Reads and validates every parameter. Throws std::invalid_argument naming the parameter:
// a wrong type, a bad value, or a key that no option read (a misspelt parameter would
// otherwise be silently ignored).
FusionParams LoadFusionParams(RosParamSource& source);
FusionParams LoadFusionParams(const ros::NodeHandle& pnh);

}  // namespace bsf_vpr
