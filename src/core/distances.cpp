#include "bsf_vpr/core/distances.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace bsf_vpr {

DistanceMetric ParseDistanceMetric(const std::string& name) {
  if (name == "euclidean") return DistanceMetric::kEuclidean;
  if (name == "cosine") return DistanceMetric::kCosine;
  throw std::invalid_argument("unknown distance '" + name + "' (expected euclidean or cosine)");
}

std::string ToString(DistanceMetric metric) {
  return metric == DistanceMetric::kEuclidean ? "euclidean" : "cosine";
}

namespace {

void CheckQueries(const RowMatrixXf& queries, const ReferenceSet& set) {
  if (queries.cols() != set.descriptors.cols()) {
    throw std::invalid_argument("query descriptors have dimension " +
                                std::to_string(queries.cols()) + ", reference set '" + set.name +
                                "' has dimension " + std::to_string(set.descriptors.cols()));
  }
  if (!queries.allFinite()) {
    for (Eigen::Index q = 0; q < queries.rows(); ++q) {
      if (!queries.row(q).allFinite()) {
        throw std::invalid_argument("query descriptor " + std::to_string(q) +
                                    " holds NaN or infinity");
      }
    }
  }
}

}  // namespace

namespace {

// Inner product with a fixed summation order: eight interleaved partial sums (which the
// compiler maps onto vector lanes), combined in a fixed tree. A query's distances are thus
// bitwise the same whether it is computed alone (online) or in a batch (offline), which a
// matrix-product library does not promise (GEMV and GEMM sum in different orders).
float FixedOrderDot(const float* a, const float* b, int n) {
  float acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    for (int k = 0; k < 8; ++k) acc[k] += a[i + k] * b[i + k];
  }
  float tail = 0;
  for (; i < n; ++i) tail += a[i] * b[i];
  return (((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]))) + tail;
}

}  // namespace

RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const ReferenceSet& set) {
  CheckQueries(queries, set);
  const RowMatrixXf& refs = set.descriptors;
  const int d = static_cast<int>(refs.cols());
  const Eigen::Index nq = queries.rows(), nr = refs.rows();
  Eigen::VectorXf qn(nq), rn(nr);  // squared norms
  for (Eigen::Index q = 0; q < nq; ++q)
    qn(q) = FixedOrderDot(queries.row(q).data(), queries.row(q).data(), d);
  for (Eigen::Index r = 0; r < nr; ++r)
    rn(r) = FixedOrderDot(refs.row(r).data(), refs.row(r).data(), d);
  RowMatrixXf out(nq, nr);
  // Blocks of queries share each reference row while it is in cache.
  constexpr Eigen::Index kBlock = 16;
  for (Eigen::Index q0 = 0; q0 < nq; q0 += kBlock) {
    const Eigen::Index q1 = std::min(nq, q0 + kBlock);
    for (Eigen::Index r = 0; r < nr; ++r) {
      const float* ref = refs.row(r).data();
      for (Eigen::Index q = q0; q < q1; ++q) {
        out(q, r) = FixedOrderDot(queries.row(q).data(), ref, d);
      }
    }
  }
  for (Eigen::Index q = 0; q < nq; ++q) {
    for (Eigen::Index r = 0; r < nr; ++r) {
      const float dot = out(q, r);
      if (metric == DistanceMetric::kEuclidean) {
        out(q, r) = std::sqrt(std::max(qn(q) + rn(r) - 2.0f * dot, 0.0f));
      } else {
        const float denom = std::sqrt(qn(q)) * std::sqrt(rn(r));
        out(q, r) = denom > 0 ? std::max(1.0f - dot / denom, 0.0f) : 1.0f;
      }
    }
  }
  return out;
}

std::vector<RowMatrixXf> ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                                          const ReferenceMap& map) {
  std::vector<RowMatrixXf> out;
  out.reserve(static_cast<size_t>(map.num_sets()));
  for (const ReferenceSet& set : map.sets()) out.push_back(ComputeDistances(metric, queries, set));
  return out;
}

std::vector<SetDistances> QueryRowViews(const std::vector<RowMatrixXf>& per_set, int query,
                                        const std::vector<const std::vector<int>*>& place_ids) {
  std::vector<SetDistances> views(per_set.size());
  for (size_t u = 0; u < per_set.size(); ++u) {
    views[u].values = per_set[u].row(query).data();
    views[u].count = static_cast<int>(per_set[u].cols());
    views[u].place_ids = (u < place_ids.size() && place_ids[u]) ? place_ids[u]->data() : nullptr;
  }
  return views;
}

float SimilarityOffset(const std::vector<const RowMatrixXf*>& similarities) {
  float offset = 1.0f;
  for (const RowMatrixXf* s : similarities) {
    if (s->size() > 0) offset = std::max(offset, s->maxCoeff());
  }
  return offset;
}

void SimilaritiesToDistances(float offset, RowMatrixXf* matrix) {
  matrix->array() = (offset - matrix->array()).max(0.0f);
}

}  // namespace bsf_vpr
