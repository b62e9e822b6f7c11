#include "bsf_vpr/core/method_runner.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

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
                             a.velocity_step == b.velocity_step && a.standardize == b.standardize &&
                             a.use_partial_sequences == b.use_partial_sequences;
  if (!same_sequence) sequence_ = SequenceMatcher(options.sequence);
  if (options.fusion != options_.fusion) adaptive_.Reset();
  if (options.off_map.enabled != options_.off_map.enabled) off_map_.Reset();
  options_ = options;
}

void MethodRunner::Reset() {
  sequence_.Reset();
  last_log_posterior_.resize(0);
  adaptive_.Reset();
  off_map_.Reset();
}

namespace {

// RunMethod on the available sets alone, its belief re-indexed to every set of `sets`.
PlaceBelief RunOnAvailable(const Method& method, const std::vector<SetDistances>& sets,
                           const std::vector<bool>& available, int num_places,
                           const MethodOptions& options, const Eigen::VectorXd* log_prior,
                           FusionStream stream, const std::vector<JointDistances>* joint) {
  if (available.size() != sets.size()) {
    throw std::invalid_argument("availability given for " + std::to_string(available.size()) +
                                " set(s), the query has " + std::to_string(sets.size()));
  }
  std::vector<SetDistances> present;
  std::vector<int> index;  // index[k]: the set of present[k]
  for (size_t u = 0; u < sets.size(); ++u) {
    if (!available[u]) continue;
    present.push_back(sets[u]);
    index.push_back(static_cast<int>(u));
  }
  if (present.empty()) throw std::invalid_argument("no set's distances are available");
  Method m = method;
  if (m.kind == MethodKind::kNearestNeighbour || m.kind == MethodKind::kBayesSingle) {
    const auto it = std::find(index.begin(), index.end(), m.set_index);
    if (it == index.end()) {
      throw std::invalid_argument("method '" + m.Name() + "' needs set '" + m.set_name +
                                  "', whose distances are missing");
    }
    m.set_index = static_cast<int>(it - index.begin());
  }
  stream.set_ids = &index;
  PlaceBelief b = RunMethod(m, present, num_places, options, log_prior, &stream, joint);
  const auto to_full = [&index](std::vector<int>* v) {
    for (int& u : *v) u = index.at(static_cast<size_t>(u));
  };
  b.selection.best = index.at(static_cast<size_t>(b.selection.best));
  to_full(&b.selection.selected);
  to_full(&b.used_sets);
  DistanceStats missing;
  missing.min = std::numeric_limits<float>::quiet_NaN();
  missing.argmin = -1;
  missing.mean = missing.stddev = std::numeric_limits<double>::quiet_NaN();
  std::vector<DistanceStats> stats(sets.size(), missing);
  std::vector<double> weights(sets.size(), 0.0);
  for (size_t k = 0; k < index.size(); ++k) {
    stats[static_cast<size_t>(index[k])] = b.selection.set_stats.at(k);
    weights[static_cast<size_t>(index[k])] = b.set_weights.at(k);
  }
  b.selection.set_stats = std::move(stats);
  b.set_weights = std::move(weights);
  return b;
}

}  // namespace

PlaceBelief MethodRunner::Step(const std::vector<SetDistances>& sets, int num_places,
                               const Eigen::VectorXd* log_prior, std::optional<double> step_places,
                               bool update_state, const std::vector<bool>* available,
                               const std::vector<JointDistances>* joint) {
  Eigen::VectorXd predicted;
  if (method_.temporal_filter && last_log_posterior_.size() == num_places) {
    predicted = PredictLogPrior(last_log_posterior_, options_.filter, step_places);
    log_prior = &predicted;
  }
  const bool all =
      !available || (available->size() == sets.size() &&
                     std::find(available->begin(), available->end(), false) == available->end());
  FusionStream stream;
  stream.state = &adaptive_;
  stream.step_places = step_places;
  stream.update_state = update_state;
  PlaceBelief b = all ? RunMethod(method_, sets, num_places, options_, log_prior, &stream, joint)
                      : RunOnAvailable(method_, sets, *available, num_places, options_, log_prior,
                                       stream, joint);
  if (update_state && method_.temporal_filter) last_log_posterior_ = b.log_posterior;
  Evidence evidence;
  evidence.kind = method_.IsBayesian() ? Evidence::Kind::kPosterior : Evidence::Kind::kDistance;
  if (options_.off_map.enabled && method_.IsBayesian() && b.log_posterior.size() == num_places) {
    evidence.log_off_odds = OffMapOdds(b.log_posterior, log_prior, step_places, update_state);
    b.off_map_probability = 1 / (1 + std::exp(-evidence.log_off_odds));
  }
  if (method_.sequence) {
    SequenceMatcher what_if = sequence_;  // a query that must leave no trace
    SequenceMatcher& matcher = update_state ? sequence_ : what_if;
    if (matcher.queries() > 0 && b.cost.size() != num_places) matcher.Reset();
    b.cost = matcher.Push(b.cost);
    evidence.kind = Evidence::Kind::kSequence;
    evidence.sequence_velocities = matcher.velocities();
  }
  evidence.sets = &sets;
  evidence.available = all ? nullptr : available;
  Decide(options_.decision, evidence, &b, rule_ ? &*rule_ : nullptr);
  return b;
}

double MethodRunner::OffMapOdds(const Eigen::VectorXd& log_posterior,
                                const Eigen::VectorXd* log_prior, std::optional<double> step_places,
                                bool update_state) {
  const Eigen::Index n = log_posterior.size();
  Eigen::VectorXd log_likelihood = log_posterior;  // the query's, without the prior's
  if (log_prior != nullptr && log_prior->size() == n) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const double p = (*log_prior)(i);
      log_likelihood(i) = p > -std::numeric_limits<double>::infinity()
                              ? log_likelihood(i) - p
                              : -std::numeric_limits<double>::infinity();
    }
  }
  return off_map_.Update(log_likelihood, options_.off_map, options_.filter, step_places,
                         update_state);
}

}  // namespace bsf_vpr
