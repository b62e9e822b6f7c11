#include "bsf_vpr/core/temporal_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace bsf_vpr {

void TemporalFilterOptions::Validate() const { TemporalFilterOptionsTable().CheckValues(*this); }

const OptionTable<TemporalFilterOptions>& TemporalFilterOptionsTable() {
  constexpr bool kLive = true;
  static const OptionTable<TemporalFilterOptions> kTable =
      OptionTable<TemporalFilterOptions>()
          .Add(
              "filter_step_mean_places", [](auto& o) -> auto& { return o.step_mean_places; },
              "+filter without odometry: mean progress per query (0 carries the belief in "
              "place)",
              "places", Finite(), kLive)
          .Add(
              "filter_step_std_places", [](auto& o) -> auto& { return o.step_std_places; },
              "+filter: standard deviation of the progress per query", "places", Finite(AtLeast(0)),
              kLive)
          .Add(
              "relocalization_probability",
              [](auto& o) -> auto& { return o.relocalization_probability; },
              "+filter: probability per query of re-localising anywhere on the map", "",
              {0, 1, true, false}, kLive);
  return kTable;
}

Eigen::VectorXd PredictLogPrior(const Eigen::VectorXd& log_posterior,
                                const TemporalFilterOptions& options,
                                std::optional<double> step_mean) {
  return PredictPrior(log_posterior.array().exp().matrix(), options, step_mean).array().log();
}

Eigen::VectorXd PredictPrior(const Eigen::VectorXd& p, const TemporalFilterOptions& options,
                             std::optional<double> step_mean) {
  options.Validate();
  const double mean = step_mean.value_or(options.step_mean_places);
  if (!std::isfinite(mean)) throw std::invalid_argument("step_mean must be finite");
  const double sd = options.step_std_places;
  const Eigen::Index n = p.size();
  // Step weights w(s) for s in [s_lo, s_hi].
  const long s_lo = sd > 0 ? static_cast<long>(std::floor(mean - 4 * sd)) : std::lround(mean);
  const long s_hi = sd > 0 ? static_cast<long>(std::ceil(mean + 4 * sd)) : std::lround(mean);
  std::vector<double> w;
  for (long s = s_lo; s <= s_hi; ++s) {
    const double z = sd > 0 ? (s - mean) / sd : 0.0;
    w.push_back(std::exp(-0.5 * z * z));
  }
  // moved(j) = sum_k w[k] p(j - s_k), the steps added in k order (a shift per step).
  Eigen::VectorXd moved = Eigen::VectorXd::Zero(n);
  for (size_t k = 0; k < w.size(); ++k) {
    const long s = s_lo + static_cast<long>(k);  // moved(j) takes p(j - s)
    const Eigen::Index from = std::max<long>(0, -s), to = std::max<long>(0, s);
    const Eigen::Index len = n - std::min<Eigen::Index>(n, std::abs(s));
    if (len > 0) moved.segment(to, len) += w[k] * p.segment(from, len);
  }
  // The steps' weights need no normalising: the moved mass is normalised as a whole (mass
  // moved past the end of the route is lost).
  const double total = moved.sum();
  const double r = options.relocalization_probability;
  if (!(total > 0)) return Eigen::VectorXd::Constant(n, 1.0 / static_cast<double>(n));
  Eigen::VectorXd prior = ((1 - r) / total) * moved.array() + r / static_cast<double>(n);
  return prior;
}

}  // namespace bsf_vpr
