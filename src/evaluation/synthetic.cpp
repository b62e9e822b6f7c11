#include "bsf_vpr/evaluation/synthetic.h"

#include <numeric>
#include <random>
#include <stdexcept>

namespace bsf_vpr {

void SyntheticOptions::Validate() const {
  if (num_places < 1) throw std::invalid_argument("num_places must be >= 1");
  if (dimension < 1) throw std::invalid_argument("dimension must be >= 1");
  if (set_noise.empty()) throw std::invalid_argument("set_noise needs one entry per set");
  if (!query_condition_weights.empty() && query_condition_weights.size() != set_noise.size()) {
    throw std::invalid_argument("query_condition_weights needs one entry per set");
  }
  for (double w : query_condition_weights) {
    if (!(w >= 0)) throw std::invalid_argument("query_condition_weights must be >= 0");
  }
  if (!query_condition_weights.empty() &&
      std::accumulate(query_condition_weights.begin(), query_condition_weights.end(), 0.0) <= 0) {
    throw std::invalid_argument("query_condition_weights must not all be zero");
  }
}

SyntheticData GenerateMultiConditionData(const SyntheticOptions& options) {
  options.Validate();
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  const int n = options.num_places;
  const int d = options.dimension;
  const int m = static_cast<int>(options.set_noise.size());
  auto gaussian = [&](int rows, int cols, double scale) {
    RowMatrixXf x(rows, cols);
    for (Eigen::Index i = 0; i < x.size(); ++i)
      x.data()[i] = static_cast<float>(scale) * normal(rng);
    return x;
  };
  const RowMatrixXf base = gaussian(n, d, 1.0);
  std::vector<RowMatrixXf> condition(static_cast<size_t>(m));
  for (int c = 0; c < m; ++c)
    condition[static_cast<size_t>(c)] = gaussian(n, d, options.condition_strength);

  SyntheticData out;
  for (int u = 0; u < m; ++u) {
    const std::string name = "c" + std::to_string(u);
    RowMatrixXf z = base + condition[static_cast<size_t>(u)] +
                    gaussian(n, d, options.set_noise[static_cast<size_t>(u)]);
    out.map.Add(MakeReferenceSet(name, std::move(z), name));
  }
  std::vector<double> weights = options.query_condition_weights;
  if (weights.empty()) {
    weights.assign(static_cast<size_t>(m), 0.0);
    weights[0] = 1.0;
  }
  std::discrete_distribution<int> pick(weights.begin(), weights.end());
  out.queries = gaussian(n, d, options.query_noise) + base;
  out.query_condition.resize(static_cast<size_t>(n));
  for (int q = 0; q < n; ++q) {
    const int c = pick(rng);
    out.query_condition[static_cast<size_t>(q)] = c;
    out.queries.row(q) += condition[static_cast<size_t>(c)].row(q);
  }
  out.truth = GroundTruth::FromFrameTolerance(n, n, 0);
  return out;
}

}  // namespace bsf_vpr
