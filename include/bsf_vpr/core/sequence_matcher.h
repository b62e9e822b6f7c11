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

namespace bsf_vpr {

struct SequenceOptions {
  int length = 5;               // L, queries per sequence (the paper's study 5 uses 5)
  double min_velocity = 0.8;    // places per query
  double max_velocity = 1.25;   // places per query
  double velocity_step = 0.05;  // places per query
  bool standardize = true;      // standardise each query's costs over places
  // Before L queries have arrived: true uses the shorter sequence of the queries so far;
  // false reports the current query's own costs until L are there.
  bool use_partial_sequences = true;

  void Validate() const;  // throws std::invalid_argument naming the bad field
};

class SequenceMatcher {
 public:
  explicit SequenceMatcher(SequenceOptions options = {});

  // Adds query t's costs (N places; +infinity marks an impossible place) and returns the
  // sequence costs seq_t (N entries, lower is better). Throws std::invalid_argument if N
  // differs from the previous queries' (call Reset when the map changes) or a cost is NaN.
  Eigen::VectorXd Push(const Eigen::VectorXd& costs);
  void Reset() { history_.clear(); }
  int queries() const { return static_cast<int>(history_.size()); }
  const SequenceOptions& options() const { return options_; }

 private:
  SequenceOptions options_;
  std::deque<Eigen::VectorXd> history_;  // newest first, at most L
};

}  // namespace bsf_vpr
