// The paper's Bayesian Selective Fusion written the straightforward way (O(N^2) indicator
// sums, no sorting, no tricks): the baseline bsf_benchmark compares the library against.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace bsf_vpr {
namespace tools {

// distances[u][i] = D^u_i (all sets cover all places). Returns the matched place.
inline int NaiveBsf(const std::vector<std::vector<float>>& distances, double gamma,
                    std::vector<double>* posterior) {
  const size_t m = distances.size(), n = distances[0].size();
  std::vector<double> mins(m);
  for (size_t u = 0; u < m; ++u)
    mins[u] = *std::min_element(distances[u].begin(), distances[u].end());
  const double best = *std::min_element(mins.begin(), mins.end());
  std::vector<double> log_post(n, -std::log(static_cast<double>(n)));  // uniform prior
  for (size_t u = 0; u < m; ++u) {
    if ((mins[u] - best) / best > gamma) continue;  // Eq. reference_selection
    const std::vector<float>& d = distances[u];
    double mean = 0, var = 0;
    for (float v : d) mean += v;
    mean /= static_cast<double>(n);
    for (float v : d) var += (v - mean) * (v - mean);
    var /= static_cast<double>(n);
    for (size_t i = 0; i < n; ++i) {
      double count = 0;  // Eq. placeMatch
      for (size_t j = 0; j < n; ++j) count += d[i] <= d[j] ? 1 : 0;
      const double log_gauss =
          -0.5 * std::log(2 * M_PI * var) - (d[i] - mean) * (d[i] - mean) / (2 * var);
      log_post[i] += std::log(count) - log_gauss;  // Eq. obsLikelihoods, product over S
    }
  }
  const double mx = *std::max_element(log_post.begin(), log_post.end());
  double z = 0;
  for (double l : log_post) z += std::exp(l - mx);
  posterior->resize(n);
  for (size_t i = 0; i < n; ++i) (*posterior)[i] = std::exp(log_post[i] - mx) / z;
  return static_cast<int>(std::max_element(posterior->begin(), posterior->end()) -
                          posterior->begin());
}

}  // namespace tools
}  // namespace bsf_vpr
