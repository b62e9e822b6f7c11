// A seeded generator of multi-condition place recognition data, for tests of mechanics and
// for studies that need more conditions than the shipped real data has.
//
// Place i has an appearance b_i ~ N(0, I). Each condition c changes every place in its own
// way, n_i^c ~ N(0, condition_strength^2 I). Reference set u was recorded under condition u:
// z_i^u = b_i + n_i^u + set_noise[u] * e. A query at place i under condition c is
// z = b_i + n_i^c + query_noise * e. A query is easy to match against the set of its own
// condition and hard against the others, so which set is informative changes per query.
#pragma once

#include <cstdint>
#include <vector>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/evaluation/evaluation.h"

namespace bsf_vpr {

struct SyntheticOptions {
  int num_places = 300;
  int dimension = 32;
  std::vector<double> set_noise = {0.3, 0.3, 0.3};  // one entry per reference set / condition
  double condition_strength = 1.0;
  double query_noise = 0.3;
  // Probability that a query is taken under each set's condition (normalised; empty means
  // all queries under condition 0).
  std::vector<double> query_condition_weights;
  uint64_t seed = 1;

  void Validate() const;  // throws std::invalid_argument naming the bad field
};

struct SyntheticData {
  ReferenceSets map;                  // sets "c0", "c1", ... with condition labels "c0", ...
  RowMatrixXf queries;               // one query per place: query q is at place q
  std::vector<int> query_condition;  // condition of each query
  GroundTruth truth;                 // query q's only correct place is q
};

SyntheticData GenerateMultiConditionData(const SyntheticOptions& options);

}  // namespace bsf_vpr
