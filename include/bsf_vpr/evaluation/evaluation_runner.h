// Runs a list of methods over a whole query traversal and scores them (the offline
// evaluation behind bsf_evaluate).
#pragma once

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/core/types.h"
#include "bsf_vpr/evaluation/evaluation.h"

namespace bsf_vpr {

struct QueryOutcome {
  int match = -1;
  double confidence = 0;
  bool accepted = false;
  double off_map_probability = 0;                                    // PlaceBelief's
  double match_distance = std::numeric_limits<double>::quiet_NaN();  // PlaceBelief's (NaN: no used
                                                                     // set covers the match)
  std::vector<int> top_places;
};

struct MethodResults {
  Method method;
  std::vector<QueryOutcome> outcomes;  // one per query
  Metrics metrics;
};

// The metrics of one method's outcomes (one per query) against `truth`.
Metrics ScoreOutcomes(const std::vector<QueryOutcome>& outcomes, const GroundTruth& truth);

// Fills (*block)[u] with the (end - begin) x N_u distances of queries [begin, end) to set u.
using DistanceBlockFn = std::function<void(int begin, int end, std::vector<RowMatrixXf>* block)>;

struct EvaluationInput {
  int num_queries = 0;
  int num_places = 0;
  std::vector<std::string> set_names;
  std::vector<std::vector<int>> place_ids;  // per set; an empty vector means row k is place k
  std::vector<int> groups;  // per set its descriptor group (SetDistances::group); empty: all 0
  DistanceBlockFn distances;
  // The joint representations of the sets (JointRepresentation) the methods need, by kind:
  // joint_distances fills (*block)[j] with the (end - begin) x num_places distances of queries
  // [begin, end) to the representation of kind joint_kinds[j].
  std::vector<JointKind> joint_kinds;
  DistanceBlockFn joint_distances;
  // Per method of the list, the map's acceptance rule (self_calibration.h; nullopt: the
  // threshold alone). Empty: none for any.
  std::vector<std::optional<AcceptanceRule>> acceptance_rules;
  // Per query, true where the camera saw nothing (a blind frame, BlindImageProblem): as the
  // ingest drops such a frame live, it is no observation: no method steps on it (a filter's
  // state is left as it was), its outcome is no match (match -1, confidence -infinity, not
  // accepted). Empty: every query was seen.
  std::vector<bool> unseen;
  // Per query, the robot's progress since the previous seen query, in places: the +filter's
  // step for it (MethodRunner::Step's step_places, as the node's odometry gives it); NaN:
  // none (the filter's own step distribution). Empty: no odometry.
  std::vector<double> odometry_steps;
};

// Where EvaluateMethods' time went: wall seconds and CPU seconds of the process (all its
// threads) in each part, summed over the blocks.
struct EvaluationPhaseTimes {
  struct Phase {
    double wall_s = 0, cpu_s = 0;
  };
  Phase distances;  // input.distances and input.joint_distances
  Phase methods;    // the methods over the queries (selection, likelihoods, fusion, decision)
  Phase metrics;    // ScoreOutcomes of every method
};

// Evaluates every method on every query, in order (+filter and +seq carry state from one
// query to the next), `block_size` queries at a time (bounding memory
// to block_size x sum N_u distances), and scores them against `truth` (which must have
// num_queries queries). `progress(done, total)` is called after each block if given;
// `times`, if given, receives the time of each part.
std::vector<MethodResults> EvaluateMethods(const EvaluationInput& input,
                                           const std::vector<Method>& methods,
                                           const MethodOptions& options, const GroundTruth& truth,
                                           const std::function<void(int, int)>& progress = {},
                                           int block_size = 256,
                                           EvaluationPhaseTimes* times = nullptr);

}  // namespace bsf_vpr
