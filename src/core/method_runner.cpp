#include "bsf_vpr/core/method_runner.h"

#include <limits>

namespace bsf_vpr {

MethodRunner::MethodRunner(Method method, MethodOptions options)
    : method_(std::move(method)), options_(std::move(options)), sequence_(options_.sequence) {
  options_.Validate();
}

void MethodRunner::SetOptions(const MethodOptions& options) {
  options.Validate();
  const SequenceOptions& a = options.sequence;
  const SequenceOptions& b = options_.sequence;
  const bool same_sequence = a.length == b.length && a.min_velocity == b.min_velocity &&
                             a.max_velocity == b.max_velocity &&
                             a.velocity_step == b.velocity_step &&
                             a.standardize == b.standardize &&
                             a.use_partial_sequences == b.use_partial_sequences;
  if (!same_sequence) sequence_ = SequenceMatcher(options.sequence);
  options_ = options;
}

void MethodRunner::Reset() {
  sequence_.Reset();
  last_log_posterior_.resize(0);
}

PlaceBelief MethodRunner::Step(const std::vector<SetDistances>& sets, int num_places,
                               const Eigen::VectorXd* log_prior, std::optional<double> step_places,
                               bool update_state) {
  Eigen::VectorXd predicted;
  if (method_.temporal_filter && last_log_posterior_.size() == num_places) {
    predicted = PredictLogPrior(last_log_posterior_, options_.filter, step_places);
    log_prior = &predicted;
  }
  PlaceBelief b = RunMethod(method_, sets, num_places, options_, log_prior);
  if (update_state && method_.temporal_filter) last_log_posterior_ = b.log_posterior;
  if (method_.sequence) {
    SequenceMatcher what_if = sequence_;  // a query that must leave no trace
    SequenceMatcher& matcher = update_state ? sequence_ : what_if;
    if (matcher.queries() > 0 && b.cost.size() != num_places) matcher.Reset();
    b.cost = matcher.Push(b.cost);
    const Eigen::VectorXd score = -b.cost;
    b.top_places = TopK(score, options_.top_k);
    b.accepted = false;
    b.confidence = -std::numeric_limits<double>::infinity();
    if (!b.top_places.empty()) {
      b.match = b.top_places.front();
      b.confidence = SequenceMatchLogOdds(b.cost, b.match, matcher.velocities());
      b.accepted = b.confidence > options_.threshold.LogOdds();
    }
  }
  return b;
}

}  // namespace bsf_vpr
