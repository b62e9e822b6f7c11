// Command-line arguments of bsf_evaluate.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/core/self_calibration.h"
#include "bsf_vpr/image/image_describer.h"
#include "src/tools/common/query_bag.h"

namespace bsf_vpr {
namespace tools {

struct NamedPath {
  std::string name;
  std::string path;
};

struct EvaluateArgs {
  // --reference NAME=PATH; with --results-bag only the place poses of the sets the node
  // had loaded, for --tolerance-m.
  std::vector<NamedPath> references;
  std::string query;                    // --query PATH
  std::vector<NamedPath> distances;     // --distances NAME=PATH
  std::vector<NamedPath> similarities;  // --similarities NAME=PATH
  bool same_descriptor = false;         // --same-descriptor: the sources are one descriptor's
  std::string results_bag;              // --results-bag PATH
  std::string belief_topic = "/bsf_vpr/belief";
  std::string truth_topic = kGroundTruthTopic;
  std::string pose_topic = kQueryPoseTopic;  // geometry_msgs/PoseStamped, for --tolerance-m
  // --distance; when not given: the distance the reference sets (and a query YAML) declare,
  // if they agree, else euclidean (evaluate_inputs.h).
  std::optional<DistanceMetric> metric;
  StoragePrecision storage = StoragePrecision::kFloat32;
  bool memory_map = false;    // --memory-map true: map reference .npy files held at `storage`
  int tolerance_frames = -1;  // --tolerance K (-1: not given)
  double tolerance_m = -1;    // --tolerance-m R (-1: not given)
  std::string query_poses;    // --query-poses CSV, for --tolerance-m and --odometry poses
  bool odometry = false;      // --odometry poses: the +filter's steps from the query poses
  double place_spacing_m = 0;  // --place-spacing-m (0: the places' median spacing)
  std::string ground_truth;   // --ground-truth PATH (.csv or .npy)
  std::string methods = "all";
  MethodOptions options;
  CalibrationOptions calibration;  // --max-false-accept-rate
  FirstStageOptions first_stage;    // descriptor inputs: exact or the pca first stage
  ImageDescriberOptions describer;  // for image folders
  std::string out_dir;
  bool progress = true;
  bool timings = false;  // --timings
  bool help = false;
};

// Parses argv. Throws std::invalid_argument with a one-line message naming the problem.
EvaluateArgs ParseEvaluateArgs(int argc, char** argv);

// Checks that the inputs and ground truth given go together (one input mode, one kind of
// ground truth) and validates the options. Throws std::invalid_argument.
void CheckCombination(const EvaluateArgs& args);

// The --help text (the image-descriptor lines from DescriberUsage()).
std::string EvaluateUsage();

}  // namespace tools
}  // namespace bsf_vpr
