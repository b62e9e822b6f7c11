// The distance metrics from an inner product and squared norms: the one formula behind
// ComputeDistances (distances.cpp) and ApproximateIndex (approximate_distances.cpp), so that
// an exact distance is the same bits in both. Distances are not squared; see distances.h.
#pragma once

#include <algorithm>
#include <cmath>

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

}  // namespace formula
}  // namespace bsf_vpr
