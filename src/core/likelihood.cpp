#include "bsf_vpr/core/likelihood.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bsf_vpr/core/selection.h"

namespace bsf_vpr {

LikelihoodVariant ParseLikelihoodVariant(const std::string& name) {
  if (name == "one_sided") return LikelihoodVariant::kOneSided;
  if (name == "two_sided") return LikelihoodVariant::kTwoSided;
  throw std::invalid_argument("unknown likelihood variant '" + name +
                              "' (expected one_sided or two_sided)");
}

std::string ToString(LikelihoodVariant variant) {
  return variant == LikelihoodVariant::kOneSided ? "one_sided" : "two_sided";
}

void RankCounts(const float* values, int count, int* counts) {
  std::vector<float> sorted(values, values + count);
  std::sort(sorted.begin(), sorted.end());
  for (int k = 0; k < count; ++k) {
    // Elements >= values[k] are those from the first one not below it to the end.
    const auto first = std::lower_bound(sorted.begin(), sorted.end(), values[k]);
    counts[k] = count - static_cast<int>(first - sorted.begin());
  }
}

void PlaceMatchLogLikelihood(const SetDistances& d, const LikelihoodOptions& options,
                             double* log_likelihood) {
  PlaceMatchLogLikelihood(d, ComputeDistanceStats(d), options, log_likelihood);
}

void PlaceMatchLogLikelihood(const SetDistances& d, const DistanceStats& st,
                             const LikelihoodOptions& options, double* log_likelihood) {
  std::vector<int> counts(static_cast<size_t>(d.count));
  RankCounts(d.values, d.count, counts.data());
  const double var = st.stddev * st.stddev;
  const double half_inv_var = var > 0 ? 0.5 / var : 0.0;
  const bool one_sided = options.variant == LikelihoodVariant::kOneSided;
  double max_ll = -INFINITY;
  for (int k = 0; k < d.count; ++k) {
    double e = d.values[k] - st.mean;
    if (one_sided) e = std::min(e, 0.0);
    log_likelihood[k] = std::log(static_cast<double>(counts[k])) + e * e * half_inv_var;
    max_ll = std::max(max_ll, log_likelihood[k]);
  }
  double sum = 0;
  for (int k = 0; k < d.count; ++k) sum += std::exp(log_likelihood[k] - max_ll);
  const double log_mean = max_ll + std::log(sum / d.count);
  for (int k = 0; k < d.count; ++k) log_likelihood[k] -= log_mean;
}

}  // namespace bsf_vpr
