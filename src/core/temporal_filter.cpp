#include "bsf_vpr/core/temporal_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "src/core/internal/vector_math.h"

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
  return LogOf(PredictPrior(ExpOf(log_posterior.array()).matrix(), options, step_mean).array())
      .matrix();
}

MotionStep MotionStepOf(const TemporalFilterOptions& options, std::optional<double> step_mean) {
  options.Validate();
  double mean = step_mean.value_or(options.step_mean_places);
  if (!std::isfinite(mean)) throw std::invalid_argument("step_mean must be finite");
  // A step beyond any map moves all the mass past its end (a uniform prior) either way; the
  // bound keeps the step's places representable.
  mean = std::clamp(mean, -1e9, 1e9);
  const double sd = options.step_std_places;
  MotionStep step;
  step.relocalization = options.relocalization_probability;
  // Step weights w(s) for s in [s_lo, s_hi].
  const long s_lo = sd > 0 ? static_cast<long>(std::floor(mean - 4 * sd)) : std::lround(mean);
  const long s_hi = sd > 0 ? static_cast<long>(std::ceil(mean + 4 * sd)) : std::lround(mean);
  step.first = s_lo;
  for (long s = s_lo; s <= s_hi; ++s) {
    const double z = sd > 0 ? (s - mean) / sd : 0.0;
    step.weights.push_back(std::exp(-0.5 * z * z));
  }
  return step;
}

namespace {

// The moved mass into `moved`, and the prior as a x moved + b: moved(j) = sum_k w[k] p(j - s_k),
// the steps added in k order. The steps' weights need no normalising: the moved mass is
// normalised as a whole (mass moved past the end of the route is lost). Where none is left
// (or the belief held NaN), `moved` is zeroed and the prior is uniform (a = 0, b = 1 / n).
std::pair<double, double> MoveMass(const MotionStep& step, const double* p, Eigen::Index n,
                                   double* moved) {
  const double total = kernels::StepSums(p, n, step.weights.data(),
                                         static_cast<int>(step.weights.size()), step.first, moved);
  if (!(total > 0)) {
    std::fill(moved, moved + n, 0.0);
    return {0.0, 1.0 / static_cast<double>(n)};
  }
  const double r = step.relocalization;
  return {(1 - r) / total, r / static_cast<double>(n)};
}

}  // namespace

void PredictPrior(const MotionStep& step, const double* p, Eigen::Index n, double* prior) {
  const auto [a, b] = MoveMass(step, p, n, prior);
  Eigen::Map<Eigen::ArrayXd> out(prior, n);
  out = a * out + b;
}

double PredictPriorTimes(const MotionStep& step, const double* p, Eigen::Index n, const double* l,
                         double* out) {
  const auto [a, b] = MoveMass(step, p, n, out);  // the prior's entries as PredictPrior's
  return kernels::ScaleShiftMultiply(out, n, a, b, l);
}

Eigen::VectorXd PredictPrior(const Eigen::VectorXd& p, const TemporalFilterOptions& options,
                             std::optional<double> step_mean) {
  Eigen::VectorXd prior(p.size());
  PredictPrior(MotionStepOf(options, step_mean), p.data(), p.size(), prior.data());
  return prior;
}

}  // namespace bsf_vpr
