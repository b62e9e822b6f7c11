#include "bsf_vpr/core/sequence_matcher.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace bsf_vpr {

void SequenceOptions::Validate() const {
  if (length < 1) throw std::invalid_argument("sequence length must be >= 1");
  if (!(min_velocity > 0) || !(max_velocity >= min_velocity)) {
    throw std::invalid_argument(
        "sequence velocities must satisfy 0 < min_velocity <= max_velocity");
  }
  if (!(velocity_step > 0)) throw std::invalid_argument("sequence velocity_step must be > 0");
}

SequenceMatcher::SequenceMatcher(SequenceOptions options) : options_(options) {
  options_.Validate();
}

namespace {

// Standardised copy: finite entries to zero mean, unit variance; +inf stays +inf.
Eigen::VectorXd Standardize(const Eigen::VectorXd& c) {
  double sum = 0, sq = 0;
  int n = 0;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    if (std::isfinite(c(i))) {
      sum += c(i);
      ++n;
    }
  }
  if (n == 0) return c;
  const double mean = sum / n;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    if (std::isfinite(c(i))) sq += (c(i) - mean) * (c(i) - mean);
  }
  const double sd = std::sqrt(sq / n);
  Eigen::VectorXd out = c;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    if (std::isfinite(c(i))) out(i) = sd > 0 ? (c(i) - mean) / sd : 0.0;
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
  const int steps = static_cast<int>(
      std::floor((options_.max_velocity - options_.min_velocity) / options_.velocity_step + 1e-9));
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
