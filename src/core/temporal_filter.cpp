#include "bsf_vpr/core/temporal_filter.h"

#include <cmath>
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
  options.Validate();
  const double mean = step_mean.value_or(options.step_mean_places);
  if (!std::isfinite(mean)) throw std::invalid_argument("step_mean must be finite");
  const double sd = options.step_std_places;
  const Eigen::Index n = log_posterior.size();
  // Step weights w(s) for s in [s_lo, s_hi].
  const long s_lo = sd > 0 ? static_cast<long>(std::floor(mean - 4 * sd)) : std::lround(mean);
  const long s_hi = sd > 0 ? static_cast<long>(std::ceil(mean + 4 * sd)) : std::lround(mean);
  std::vector<double> w;
  double wsum = 0;
  for (long s = s_lo; s <= s_hi; ++s) {
    const double z = sd > 0 ? (s - mean) / sd : 0.0;
    w.push_back(std::exp(-0.5 * z * z));
    wsum += w.back();
  }
  const Eigen::VectorXd p = log_posterior.array().exp();
  Eigen::VectorXd moved = Eigen::VectorXd::Zero(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    double acc = 0;
    for (size_t k = 0; k < w.size(); ++k) {
      const Eigen::Index from = j - (s_lo + static_cast<long>(k));
      if (from >= 0 && from < n) acc += w[k] * p(from);
    }
    moved(j) = acc / wsum;
  }
  const double total = moved.sum();
  const double r = options.relocalization_probability;
  Eigen::VectorXd prior = Eigen::VectorXd::Constant(n, r / static_cast<double>(n));
  if (total > 0)
    prior += (1 - r) * moved / total;
  else
    prior = Eigen::VectorXd::Constant(n, 1.0 / static_cast<double>(n));
  return prior.array().log();
}

}  // namespace bsf_vpr
