// Causal sequence matching (SeqSLAM, Milford & Wyeth 2012) on top of any method's per-query
// place costs: for the current query t and each place i, the cost of the best straight
// trajectory through the last L queries that ends at i,
//
//   seq_t(i) = min over v in [min_velocity, max_velocity] of
//              mean over k = 0..L-1 of  c_{t-k}( round(i - v k) )
//
// where c_t is query t's cost vector (lower is better), each optionally standardised to zero
// mean and unit variance over places so that queries weigh alike (SeqSLAM's contrast
// normalisation). Only past queries are used, so it runs online. Trajectory points that fall
// before place 0 (at the start of the route) are left out of the mean.
#pragma once

#include <Eigen/Core>
#include <deque>
#include <string>

#include "bsf_vpr/core/options.h"

namespace bsf_vpr {

// Bounds that keep one query's sequence search small (N x L x velocities evaluations).
constexpr int kMaxSequenceLength = 1000;
constexpr double kMaxSequenceVelocity = 1000;  // places per query
constexpr double kMaxSequenceVelocities = 1000;

struct SequenceOptions {
  int length = 5;               // L, queries per sequence (the paper's study 5 uses 5)
  double min_velocity = 0.8;    // places per query
  double max_velocity = 1.25;   // places per query
  double velocity_step = 0.05;  // places per query
  bool standardize = true;      // standardise each query's costs over places
  // Before L queries have arrived: true uses the shorter sequence of the queries so far;
  // false reports the current query's own costs until L are there.
  bool use_partial_sequences = true;

  // Throws std::invalid_argument naming the bad field (the bounds of SequenceOptionsTable),
  // also when the search would be unbounded (more than kMaxSequenceVelocities velocities).
  void Validate() const;
};

// sequence_length, sequence_use_partial and the velocities (part of MethodOptionsTable,
// methods.h); standardize is not an option.
const OptionTable<SequenceOptions>& SequenceOptionsTable();

// The confidence of a +seq match, comparable across queries and independent of the cost
// scale: the log-odds that the best sequence (cost sequence_costs(best)) is not a chance
// alignment. Its z-score z = (mean - cost_best) / sd over the n places with finite cost is
// compared with the maximum of m = n x hypotheses_per_place standard normals (the
// sequences searched, each place's best over the velocities, where nothing matches):
// P = Phi(z)^m, and the result is log(P / (1 - P)). So a threshold h given as a probability
// means "P(the best sequence is no accident) > h" for every base method, under an idealised
// null: real routes alias along their length and consecutive queries are correlated, so the
// nominal P is optimistic there (docs/method.md, "Confidence and acceptance", gives the
// precision measured at several h).
// -infinity for an impossible best place; 0 with fewer than two candidate places.
double SequenceMatchLogOdds(const Eigen::VectorXd& sequence_costs, int best,
                            int hypotheses_per_place = 1);

class SequenceMatcher {
 public:
  explicit SequenceMatcher(SequenceOptions options = {});

  // Adds query t's costs (N places; +infinity marks an impossible place) and returns the
  // sequence costs seq_t (N entries, lower is better). Throws std::invalid_argument if N
  // differs from the previous queries' (call Reset when the map changes) or a cost is NaN.
  Eigen::VectorXd Push(const Eigen::VectorXd& costs);
  void Reset() { history_.clear(); }
  int queries() const { return static_cast<int>(history_.size()); }
  int velocities() const;  // how many velocities each place's sequence is searched over
  const SequenceOptions& options() const { return options_; }

 private:
  SequenceOptions options_;
  std::deque<Eigen::VectorXd> history_;  // newest first, at most L
};

}  // namespace bsf_vpr
