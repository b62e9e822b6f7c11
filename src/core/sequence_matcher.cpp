#include "bsf_vpr/core/sequence_matcher.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace bsf_vpr {

void SequenceOptions::Validate() const {
  SequenceOptionsTable().CheckValues(*this);  // each field's bounds
  if (!(max_velocity >= min_velocity)) {
    throw std::invalid_argument(
        "sequence velocities must satisfy sequence_min_velocity <= sequence_max_velocity, got " +
        std::to_string(min_velocity) + " and " + std::to_string(max_velocity));
  }
  // Computed in double before any conversion to int: a tiny step cannot overflow.
  const double velocities = (max_velocity - min_velocity) / velocity_step + 1;
  if (!(velocities <= kMaxSequenceVelocities)) {
    throw std::invalid_argument(
        "sequence_velocity_step " + std::to_string(velocity_step) + " gives " +
        std::to_string(velocities) + " velocities between " + std::to_string(min_velocity) +
        " and " + std::to_string(max_velocity) + "; at most " +
        std::to_string(kMaxSequenceVelocities) + " are searched (use a larger step)");
  }
}

const OptionTable<SequenceOptions>& SequenceOptionsTable() {
  constexpr bool kLive = true;
  static const OptionTable<SequenceOptions> kTable =
      OptionTable<SequenceOptions>()
          .Add(
              "sequence_length", [](auto& o) -> auto& { return o.length; },
              "+seq: queries per sequence", "queries", Between(1, kMaxSequenceLength), kLive)
          .Add(
              "sequence_use_partial", [](auto& o) -> auto& { return o.use_partial_sequences; },
              "+seq: before sequence_length queries have arrived, match the shorter sequence "
              "so far (true) or the single query (false)",
              "", {}, kLive)
          .Add(
              "sequence_min_velocity", [](auto& o) -> auto& { return o.min_velocity; },
              "+seq: slowest progress searched", "places per query",
              {0, kMaxSequenceVelocity, true, false}, kLive)
          .Add(
              "sequence_max_velocity", [](auto& o) -> auto& { return o.max_velocity; },
              "+seq: fastest progress searched", "places per query",
              {0, kMaxSequenceVelocity, true, false}, kLive)
          .Add(
              "sequence_velocity_step", [](auto& o) -> auto& { return o.velocity_step; },
              "+seq: step between the velocities searched", "places per query", Above(0), kLive);
  return kTable;
}

namespace {

// Mean and population standard deviation of the finite entries of `c`, and their count.
struct FiniteStats {
  double mean = 0, sd = 0;
  int n = 0;
};
FiniteStats StatsOfFinite(const Eigen::VectorXd& c) {
  FiniteStats st;
  double sum = 0;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    if (std::isfinite(c(i))) {
      sum += c(i);
      ++st.n;
    }
  }
  if (st.n == 0) return st;
  st.mean = sum / st.n;
  double sq = 0;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    if (std::isfinite(c(i))) sq += (c(i) - st.mean) * (c(i) - st.mean);
  }
  st.sd = std::sqrt(sq / st.n);
  return st;
}

}  // namespace

double SequenceMatchLogOdds(const Eigen::VectorXd& sequence_costs, int best,
                            int hypotheses_per_place) {
  if (best < 0 || best >= sequence_costs.size() || !std::isfinite(sequence_costs(best))) {
    return -std::numeric_limits<double>::infinity();
  }
  const FiniteStats st = StatsOfFinite(sequence_costs);
  const int n = st.n;
  if (n < 2) return 0;  // one candidate place: no evidence either way
  const double z = st.sd > 0 ? (st.mean - sequence_costs(best)) / st.sd : 0.0;
  // P(no chance alignment beats z) = Phi(z)^m under a standard normal null, m hypotheses;
  // log-odds of it.
  const double m = static_cast<double>(n) * std::max(1, hypotheses_per_place);
  const double q = 0.5 * std::erfc(z / std::sqrt(2.0));  // upper tail Q(z)
  if (q > 1e-300) {
    const double log_ok = m * std::log1p(-q);
    const double not_ok = -std::expm1(log_ok);
    if (not_ok > 0) return log_ok - std::log(not_ok);
    return -(std::log(m) + std::log(q));
  }
  // Q(z) underflows: its asymptotic log, log Q ~ -z^2/2 - log(z sqrt(2 pi)).
  const double log_q = -0.5 * z * z - std::log(z) - 0.5 * std::log(2 * M_PI);
  return -(std::log(m) + log_q);
}

SequenceMatcher::SequenceMatcher(SequenceOptions options) : options_(options) {
  options_.Validate();
}

int SequenceMatcher::velocities() const {
  return 1 + static_cast<int>(std::floor(
                 (options_.max_velocity - options_.min_velocity) / options_.velocity_step + 1e-9));
}

namespace {

// Standardised copy: finite entries to zero mean, unit variance; +inf stays +inf.
Eigen::VectorXd Standardize(const Eigen::VectorXd& c) {
  const FiniteStats st = StatsOfFinite(c);
  if (st.n == 0) return c;
  Eigen::VectorXd out = c;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    if (std::isfinite(c(i))) out(i) = st.sd > 0 ? (c(i) - st.mean) / st.sd : 0.0;
  }
  return out;
}

}  // namespace

Eigen::VectorXd SequenceMatcher::Push(const Eigen::VectorXd& costs) {
  if (!history_.empty() && history_.front().size() != costs.size()) {
    throw std::invalid_argument("sequence matching: query has " + std::to_string(costs.size()) +
                                " places, the previous ones " +
                                std::to_string(history_.front().size()));
  }
  if (costs.hasNaN()) throw std::invalid_argument("sequence matching: a cost is NaN");
  history_.push_front(options_.standardize ? Standardize(costs) : costs);
  while (static_cast<int>(history_.size()) > options_.length) history_.pop_back();
  const int l = static_cast<int>(history_.size());
  if (l < options_.length && !options_.use_partial_sequences) return history_.front();

  const Eigen::Index n = costs.size();
  Eigen::VectorXd best = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  const int steps = velocities() - 1;  // bounded by Validate
  for (int s = 0; s <= steps; ++s) {
    const double v = options_.min_velocity + s * options_.velocity_step;
    for (Eigen::Index i = 0; i < n; ++i) {
      double sum = 0;
      int used = 0;
      for (int k = 0; k < l; ++k) {
        const long p = std::lround(static_cast<double>(i) - v * k);
        if (p < 0 || p >= n) continue;
        sum += history_[static_cast<size_t>(k)](p);
        ++used;
      }
      const double mean = sum / used;  // k = 0 is always inside
      if (mean < best(i)) best(i) = mean;
    }
  }
  return best;
}

}  // namespace bsf_vpr
