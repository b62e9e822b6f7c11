#include "bsf_vpr/core/off_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "src/core/internal/fusion_parts.h"
#include "src/core/internal/vector_math.h"

namespace bsf_vpr {

void OffMapOptions::Validate() const { OffMapOptionsTable().CheckValues(*this); }

const OptionTable<OffMapOptions>& OffMapOptionsTable() {
  constexpr bool kLive = true;
  static const OptionTable<OffMapOptions> kTable =
      OptionTable<OffMapOptions>()
          .Add(
              "off_map", [](auto& o) -> auto& { return o.enabled; },
              "Bayesian methods: the belief holds the hypothesis that the query shows no place "
              "of the map (off the route, a covered camera), which a match must also beat to "
              "be accepted; false gives the paper's belief, over the places alone",
              "", {}, kLive)
          .Add(
              "off_map_leave_probability", [](auto& o) -> auto& { return o.leave_probability; },
              "off_map: probability per query of leaving the map from any place (past either "
              "end of the route it is left anyway)",
              "", {0, 1, true, false}, kLive)
          .Add(
              "off_map_enter_probability", [](auto& o) -> auto& { return o.enter_probability; },
              "off_map: probability per query of entering the map, at any place, from off it", "",
              {0, 1, true, false}, kLive)
          .Add(
              "off_map_match_excess", [](auto& o) -> auto& { return o.match_excess; },
              "off_map: how many times the spread of the best non-matching places a shown "
              "place stands out by, on average (its evidence against 'no place')",
              "", Finite(AtLeast(1)), kLive);
  return kTable;
}

double OffMapLogBayesFactor(const double* ll, int n, double match_excess) {
  // The top candidates hold the first kTailPeaks + 2 peaks: each peak suppresses at most
  // 2 kPeakSeparationPlaces + 1 places.
  constexpr int kPeaks = kTailPeaks + 2;
  const int window = 2 * kPeakSeparationPlaces + 1;
  const int candidates = std::min(n, kPeaks * window);
  thread_local std::vector<int> order;
  order.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) order[static_cast<size_t>(i)] = i;
  const auto higher = [ll](int a, int b) { return ll[a] > ll[b] || (ll[a] == ll[b] && a < b); };
  if (candidates < n) {
    std::nth_element(order.begin(), order.begin() + candidates, order.end(), higher);
  }
  std::sort(order.begin(), order.begin() + candidates, higher);
  double peaks[kPeaks];
  int found = 0, taken[kPeaks];
  for (int c = 0; c < candidates && found < kPeaks; ++c) {
    const int i = order[static_cast<size_t>(c)];
    if (!std::isfinite(ll[i])) break;
    bool near = false;
    for (int k = 0; k < found && !near; ++k) near = std::abs(taken[k] - i) <= kPeakSeparationPlaces;
    if (near) continue;
    taken[found] = i;
    peaks[found++] = ll[i];
  }
  if (found < 4) return 0;
  // beta: the mean excess of peaks 2 .. found - 1 over the last one.
  double excess = 0;
  for (int k = 1; k < found - 1; ++k) excess += peaks[k] - peaks[found - 1];
  const double beta = excess / (found - 2);
  if (!(beta > 0)) return 0;
  const double g = std::min((peaks[0] - peaks[1]) / beta, 1e3);
  return g * (1 - 1 / match_excess) - std::log(match_excess);
}

double ConfidenceWithOffMap(double on_odds, double log_off_odds) {
  // P(match) = P(on) s(c), s the logistic; its log-odds are
  // -log(e^-c + (P(off) / P(on)) (1 + e^-c)).
  if (log_off_odds == -std::numeric_limits<double>::infinity()) return on_odds;
  if (std::isnan(on_odds)) return on_odds;
  const double a = -on_odds;
  const double log1p_exp_a = a > 0 ? a + std::log1p(std::exp(-a)) : std::log1p(std::exp(a));
  const double b = log_off_odds + log1p_exp_a;
  const double hi = std::max(a, b);
  if (hi == std::numeric_limits<double>::infinity()) return -hi;
  return -(hi + std::log1p(std::exp(std::min(a, b) - hi)));
}

namespace {

// log(p / (1 - p)) for P(off) = p, finite where p rounds to 1.
double OffOdds(double p) { return std::log(p) - std::log(std::max(1 - p, 1e-300)); }

}  // namespace

void OffMapTracker::Reset() {
  last_.resize(0);
  on_.resize(0);
  off_ = kOffMapInitialProbability;
}

double OffMapTracker::Update(const Eigen::VectorXd& log_likelihood, const OffMapOptions& options,
                             const TemporalFilterOptions& filter, std::optional<double> step,
                             bool update_state) {
  const Eigen::Index n = log_likelihood.size();
  const double kept_odds = OffOdds(off_);
  if (n == 0) return kept_odds;
  if (on_.size() == n && last_.size() == n &&
      internal::Correlation(log_likelihood.array(), last_.array()) >= kSameScene) {
    return kept_odds;  // the same scene again: nothing new
  }
  Eigen::VectorXd on;
  double off = off_;
  const double q_out = options.leave_probability, q_in = options.enter_probability;
  if (on_.size() != n) {  // the first query, or another map: from the start
    off = kOffMapInitialProbability;
    on = Eigen::VectorXd::Constant(n, (1 - off) / static_cast<double>(n));
  } else {
    // Predict: the filter's motion, the mass past either end going off.
    const MotionStep motion = MotionStepOf(filter, step);
    double weights = 0;
    for (double w : motion.weights) weights += w;
    on.resize(n);
    const double total_on = on_.sum();
    const double kept =
        kernels::StepSums(on_.data(), n, motion.weights.data(),
                          static_cast<int>(motion.weights.size()), motion.first, on.data()) /
        weights;
    const double past = std::max(total_on - kept, 0.0);
    const double r = motion.relocalization;
    on = (1 - q_out) *
         ((1 - r) / weights * on.array() + r * total_on / static_cast<double>(n)).matrix();
    on.array() += q_in * off_ / static_cast<double>(n);
    off = off_ * (1 - q_in) + q_out * total_on + (1 - q_out) * (1 - r) * past;
  }
  // Update: L(i) of mean 1 over the places, times the query's Bayes factor.
  const double max_ll = log_likelihood.maxCoeff();
  double log_scale = 0;
  if (std::isfinite(max_ll)) {
    scratch_.resize(n);
    const double sum = kernels::SumExp(log_likelihood.data(), n, max_ll);
    log_scale =
        OffMapLogBayesFactor(log_likelihood.data(), static_cast<int>(n), options.match_excess) -
        std::log(sum / static_cast<double>(n));
    // on(i) L(i) = on(i) exp(ll(i) - max + log_scale): scaled so that exp never overflows.
    const double shift = std::min(log_scale, 0.0);
    kernels::Exp(log_likelihood.data(), n, max_ll - shift, scratch_.data());
    on.array() *= scratch_.array();
    off *= std::exp(-(log_scale - shift));
  }
  const double z = on.sum() + off;
  if (!(z > 0) || !std::isfinite(z)) {  // nothing left: start again
    on = Eigen::VectorXd::Constant(n, (1 - kOffMapInitialProbability) / static_cast<double>(n));
    off = kOffMapInitialProbability;
  } else {
    on /= z;
    off /= z;
  }
  const double log_odds = OffOdds(off);
  if (update_state) {
    on_ = std::move(on);
    off_ = off;
    last_ = log_likelihood;
  }
  return log_odds;
}

}  // namespace bsf_vpr
