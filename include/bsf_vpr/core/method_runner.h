// Runs one method query after query, carrying what its +filter and +seq suffixes need from
// one query to the next (the previous posterior, the last L cost vectors), the adaptive
// fusion's hypotheses and the off-map tracker; then decides (decision.h). The offline
// evaluator and the online decider both use it, so a replay gives the offline results.
//
// Not thread-safe: callers serialise access.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "bsf_vpr/core/decision.h"
#include "bsf_vpr/core/methods.h"

namespace bsf_vpr {

class MethodRunner {
 public:
  MethodRunner(Method method, MethodOptions options);

  // Recognises one query from its distances to every set (see RunMethod). `log_prior`, if
  // given, is the prior for a method without +filter (null: uniform). `step_places`, if
  // given, replaces the filter's mean step for this query (odometry). With update_state the
  // query is appended to the history; without, the runner is left as it was.
  // With +seq, match, top_places and cost describe the best sequence ending at each place;
  // confidence is SequenceMatchLogOdds of the match and accepted compares it with h.
  // Bayesian methods with off_map: off_map_probability is the tracker's (off_map.h), and the
  // confidence (of the place, or of the sequence) is against "no place" too.
  //
  // `available` (null: every set) marks the sets whose distances this query has: a set of a
  // sharded map whose shard did not answer is left out, and the method runs on the others
  // as if it were not loaded, its history (over places) carried as usual. The belief still
  // indexes the sets of `sets`: a missing set has weight 0, is neither selected nor used,
  // and its statistics are NaN. Throws std::invalid_argument (history untouched) when no
  // set is available, or the method is nn:/bayes: of a missing set. `joint`: the query's
  // distances to the joint representations the method needs (RunMethod).
  PlaceBelief Step(const std::vector<SetDistances>& sets, int num_places,
                   const Eigen::VectorXd* log_prior, std::optional<double> step_places,
                   bool update_state, const std::vector<bool>* available = nullptr,
                   const std::vector<JointDistances>* joint = nullptr);

  // Forgets the history (call when the map or the traversal changes).
  void Reset();
  // Replaces the options (validated; throws std::invalid_argument and keeps the old ones).
  // The history is kept, except the sequence history when the sequence options change.
  void SetOptions(const MethodOptions& options);
  const Method& method() const { return method_; }
  // The map's acceptance rule (decision.h, self_calibration.h), applied from the next query
  // on beside the threshold; nullopt: the threshold alone. The carried state is kept.
  void SetAcceptanceRule(std::optional<AcceptanceRule> rule) { rule_ = rule; }
  const std::optional<AcceptanceRule>& acceptance_rule() const { return rule_; }

 private:
  // The off-map tracker's log(P(off) / P(on)) after this query's posterior.
  double OffMapOdds(const Eigen::VectorXd& log_posterior, const Eigen::VectorXd* log_prior,
                    std::optional<double> step_places, bool update_state);

  Method method_;
  MethodOptions options_;
  SequenceMatcher sequence_;
  Eigen::VectorXd last_log_posterior_;  // for +filter; empty before the first query
  AdaptiveFusion adaptive_;             // for bsf with fusion adaptive
  OffMapTracker off_map_;               // for Bayesian methods with off_map
  std::optional<AcceptanceRule> rule_;
};

}  // namespace bsf_vpr
