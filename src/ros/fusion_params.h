// Parameters of the fusion node, read from its private namespace (config/fusion.yaml
// documents each one with its default and unit).
#pragma once

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "bsf_vpr/core/place_recognizer.h"
#include "odometry_tracker.h"

namespace bsf_vpr {

struct ReferenceSetEntry {
  std::string name;       // required for a .npy; overrides a YAML's name if set
  std::string path;       // descriptor .npy or reference-set .yaml
  std::string condition;  // optional
};

struct FusionParams {
  RecognizerOptions recognizer;
  std::vector<ReferenceSetEntry> reference_sets;
  std::string data_directory;   // services read and write files only below it (created)
  bool distance_given = false;  // "distance" was set (not ""); else the loaded sets' own
  StoragePrecision storage = StoragePrecision::kFloat32;  // of every set loaded
  std::string map_frame = "map";
  std::string place_frame = "vpr_place";
  bool publish_tf = true;
  int belief_top_k = 0;           // 0: the belief message carries every place
  int queue_size = 100;           // descriptors buffered before the oldest are dropped
  double marker_spacing_m = 1.0;  // route layout for places without poses
  // Odometry for +filter methods: "none", "topic" (nav_msgs/Odometry on odometry_topic) or
  // "tf" (odom_frame -> base_frame). The distance travelled between two queries divided by
  // the place spacing (place_spacing_m, or the median spacing of the place poses when 0) is
  // the filter's step for that query.
  OdometrySource odometry_source = OdometrySource::kNone;
  std::string odometry_topic = "odom";
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  double place_spacing_m = 0;
  // (diagnostic_period, seconds, is read by diagnostic_updater itself.)
};

// Reads and validates every parameter. Throws std::invalid_argument naming the parameter:
// a wrong type, a bad value, or a key that is not a parameter of this node (a misspelt
// parameter would otherwise be silently ignored).
FusionParams LoadFusionParams(const ros::NodeHandle& pnh);

// The names LoadFusionParams accepts (also the dynamic_reconfigure ones).
const std::vector<std::string>& FusionParamNames();

// Threshold from its two parameters: kind "probability" or "log_odds".
Threshold MakeThreshold(double value, const std::string& kind);

}  // namespace bsf_vpr
