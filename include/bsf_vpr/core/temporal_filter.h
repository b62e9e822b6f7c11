// A forward (Bayes) filter over places, supplying the prior P(X) of Eq. bayes for the next
// query from the current posterior: the robot moves forward along the route by a step of
// s places with probability w(s) (a discretised Gaussian of mean step_mean_places and
// standard deviation step_std_places), and re-localises anywhere with a small probability,
// so that a wrong belief is recovered from:
//
//   prior_{t+1}(j) = (1 - r) * sum_s w(s) P_t(j - s) / Z  +  r / N
//
// Z renormalises the mass that moved past the end of the route. Without odometry the step
// distribution is a parameter; with odometry the caller passes the step travelled (the
// distance travelled divided by the place spacing) as step_mean for that query.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "bsf_vpr/core/options.h"

namespace bsf_vpr {

struct TemporalFilterOptions {
  double step_mean_places = 1.0;             // expected progress per query, places
  double step_std_places = 1.0;              // its standard deviation, places (>= 0)
  double relocalization_probability = 0.01;  // r, in (0, 1]

  // Throws std::invalid_argument naming the bad field (the bounds of
  // TemporalFilterOptionsTable).
  void Validate() const;
};

// filter_step_mean_places, filter_step_std_places and relocalization_probability (part of
// MethodOptionsTable, methods.h).
const OptionTable<TemporalFilterOptions>& TemporalFilterOptionsTable();

// The log prior for the next query from `log_posterior` (N entries, normalised). step_mean,
// if given, replaces options.step_mean_places (odometry). Returns N finite entries.
Eigen::VectorXd PredictLogPrior(const Eigen::VectorXd& log_posterior,
                                const TemporalFilterOptions& options,
                                std::optional<double> step_mean = std::nullopt);
// The same in probabilities: the prior from `posterior` (N non-negative entries, of any
// total: the moved mass is normalised), N positive entries summing to 1. PredictLogPrior(l) is the
// log of PredictPrior(exp(l)).
Eigen::VectorXd PredictPrior(const Eigen::VectorXd& posterior, const TemporalFilterOptions& options,
                             std::optional<double> step_mean = std::nullopt);

// One query's motion model, made once for several beliefs: the step weights w(s) for
// s = first, first + 1, ... (not normalised) and r. moved(j) = sum_s w(s) P(j - s) is
// kernels::StepSums over them. Validates the options; step_mean as for PredictPrior.
struct MotionStep {
  long first = 0;
  std::vector<double> weights;
  double relocalization = 0.01;
};
MotionStep MotionStepOf(const TemporalFilterOptions& options,
                        std::optional<double> step_mean = std::nullopt);
// PredictPrior with the step made once: the n entries of the prior from `posterior` written
// to `prior` (which must not overlap it).
void PredictPrior(const MotionStep& step, const double* posterior, Eigen::Index n, double* prior);
// The same prior times a likelihood: out = prior * l entry by entry (out must overlap
// neither `posterior` nor l), in one pass after the step; returns sum_j out[j] (the predictive
// probability of the likelihood's observation, up to l's scale), added in the fixed order of
// kernels::SumExp.
double PredictPriorTimes(const MotionStep& step, const double* posterior, Eigen::Index n,
                         const double* l, double* out);

}  // namespace bsf_vpr
