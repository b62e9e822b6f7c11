// bsf_evaluate --results-bag: the beliefs a node published during a replay, read back from
// a recorded bag, as the per-query outcomes of the offline evaluation.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/types.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"

namespace bsf_vpr {
namespace tools {

struct ResultsBag {
  std::string method;                  // as named in the beliefs
  std::vector<std::string> set_names;  // of the first belief
  int num_places = 0;
  std::vector<QueryOutcome> outcomes;  // one per query
  std::optional<GroundTruth> truth;    // the ground truth recorded in the bag, if any
  int missing = 0;                     // queries of the recorded ground truth without a belief
  // With a pose topic: each query's pose, from the geometry_msgs/PoseStamped whose header
  // stamp is the query's (the stamp of its ground truth, or else of its belief); nullopt
  // for a query without one.
  std::vector<std::optional<PlacePose>> query_poses;
  int num_poses = 0;  // PoseStamped messages on the pose topic
};

// Reads bsf_vpr/Belief messages from `belief_topic` and, if present, the
// bsf_vpr/QueryGroundTruth messages of `truth_topic`. With recorded ground truth, each belief
// is the outcome of the query with the same stamp, and a query without a belief counts as a
// wrong match with the lowest confidence; without, the k-th belief is query k. With a
// non-empty `pose_topic`, also the query poses recorded there. Throws std::runtime_error
// naming the problem (unreadable bag, no beliefs, several methods, two poses with one stamp).
ResultsBag ReadResultsBag(const std::string& path, const std::string& belief_topic,
                          const std::string& truth_topic, const std::string& pose_topic = "");

}  // namespace tools
}  // namespace bsf_vpr
