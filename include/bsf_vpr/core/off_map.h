// The hypothesis "the query shows no place of the map" (docs/method.md, "Not on the map").
//
// The training-free likelihood of a Bayesian method is a ratio against the non-match model,
// L(i) = P(D | X = i) / P(D | no place), known up to a factor: the methods normalise it to
// mean 1 over the places, the value its expectation takes when no place matches. Under
// that scale a query alone cannot tell "on the map, somewhere" from "off the map": both
// predict it equally. Two things can:
//
//   the gap of its best place   With p_1 > p_2 > ... the log-likelihoods of the query's
//                               peaks (each the best of its place and the kPeakSeparation
//                               places either side), the upper tail of a non-match model is
//                               exponential to first order (extreme value theory), so with no
//                               place shown, p_1 - p_2 ~ Exp(beta), beta estimated from the
//                               peaks 2 .. kTailPeaks + 1 (their mean excess over the next),
//                               while a shown place stands out by kappa times that:
//                               g = (p_1 - p_2) / beta ~ Exp(kappa). The Bayes factor of
//                               "shown" against "none" is B = exp(g (1 - 1/kappa)) / kappa.
//   the route                   a robot on the map moves along it: the filter of +filter over
//                               the places and one state "off", where the mass that moves
//                               past either end of the route goes off, the places lose
//                               leave_probability to it per query, and it returns
//                               enter_probability to a place drawn uniformly.
//
// The tracker filters P(X = i, on) and P(off) with the likelihoods B L(i) and 1. Its
// P(off) scales the method's belief over the places: P(X = i) = (1 - P(off)) P(X = i | on).
// A query that shows the same scene as the last one counted (log-likelihoods correlated at
// kSameScene or more: a robot standing still) is no new evidence and no motion: it leaves
// the tracker as it was.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/temporal_filter.h"

namespace bsf_vpr {

struct OffMapOptions {
  bool enabled = true;              // off_map (false: the paper's belief, over places only)
  double leave_probability = 0.01;  // per query, from any place
  double enter_probability = 0.01;  // per query, from off the map to a place
  double match_excess = 4;          // kappa: a shown place's gap over the tail's scale

  void Validate() const;  // throws std::invalid_argument naming the bad field
};
const OptionTable<OffMapOptions>& OffMapOptionsTable();

// P(off) before any query.
constexpr double kOffMapInitialProbability = 0.5;
// Peaks are at least this many places apart (the neighbours of a shown place look alike).
constexpr int kPeakSeparationPlaces = 3;
// Peaks whose excesses estimate the tail's scale.
constexpr int kTailPeaks = 10;
// Queries whose log-likelihoods correlate at least this much show the same scene.
constexpr double kSameScene = 0.99;

// log B of one query from its per-place log-likelihoods (n >= 1 entries, any constant;
// -inf allowed): 0 where there are too few peaks to estimate the tail (fewer than 4).
double OffMapLogBayesFactor(const double* log_likelihood, int n, double match_excess);

// The belief's confidence (log-odds of the match) once P(off) is part of it: `on_odds` the
// log-odds of the match among the places, `log_off_odds` log(P(off) / P(on)). Equals
// on_odds where P(off) is 0.
double ConfidenceWithOffMap(double on_odds, double log_off_odds);

// The filter over places and "off" for one stream of queries. Not thread-safe.
class OffMapTracker {
 public:
  // One query: `log_likelihood` holds the method's log P(D | X = i) up to a constant (its
  // log posterior less its log prior), `step` the progress since the previous query
  // (odometry; else the filter's mean step). Returns log(P(off) / P(on)) after it. Without
  // update_state the tracker is left as it was.
  double Update(const Eigen::VectorXd& log_likelihood, const OffMapOptions& options,
                const TemporalFilterOptions& filter, std::optional<double> step, bool update_state);
  void Reset();

 private:
  Eigen::VectorXd on_;  // P(X = i, on); empty before the first query
  double off_ = kOffMapInitialProbability;
  Eigen::VectorXd last_;  // the last counted query's log-likelihoods
  Eigen::VectorXd scratch_;
};

}  // namespace bsf_vpr
