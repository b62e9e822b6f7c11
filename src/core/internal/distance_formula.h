// The distance metrics from an inner product and squared norms: the one formula behind
// ComputeDistances (distances.cpp) and ApproximateIndex (approximate_distances.cpp), so that
// an exact distance is the same bits in both. Distances are not squared; see distances.h.
#pragma once

#include <algorithm>
#include <cmath>

#include "bsf_vpr/core/distances.h"

namespace bsf_vpr {
namespace formula {

// sqrt(max(||q||^2 + ||r||^2 - 2 q.r, 0)).
inline float Euclidean(float query_squared_norm, float row_squared_norm, float dot) {
  return std::sqrt(std::max(query_squared_norm + row_squared_norm - 2.0f * dot, 0.0f));
}

// max(1 - q.r / (||q|| ||r||), 0), or 1 when either vector is zero. `query_norm` is ||q||
// (not squared: one square root per query), `row_squared_norm` ||r||^2.
inline float Cosine(float query_norm, float row_squared_norm, float dot) {
  const float denom = query_norm * std::sqrt(row_squared_norm);
  return denom > 0 ? std::max(1.0f - dot / denom, 0.0f) : 1.0f;
}

// row[r] from the inner product it holds to the distance, for r0 <= r < r1: one loop per
// metric, without branches, so that the compiler vectorises the square roots.
inline void ToDistances(DistanceMetric metric, float query_squared_norm,
                        const float* row_squared_norms, int r0, int r1, float* row) {
  if (metric == DistanceMetric::kEuclidean) {
    for (int r = r0; r < r1; ++r)
      row[r] = Euclidean(query_squared_norm, row_squared_norms[r], row[r]);
  } else {
    const float query_norm = std::sqrt(query_squared_norm);
    for (int r = r0; r < r1; ++r) row[r] = Cosine(query_norm, row_squared_norms[r], row[r]);
  }
}

}  // namespace formula
}  // namespace bsf_vpr
