#include "bsf_vpr/core/distances.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <thread>

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

namespace {

std::atomic<int> g_threads{0};  // 0: hardware concurrency

// Computes out(q, r) for every query and the reference rows [r0, r1).
void DistanceRows(DistanceMetric metric, const RowMatrixXf& queries, const RowMatrixXf& refs,
                  const Eigen::VectorXf& qn, Eigen::Index r0, Eigen::Index r1, RowMatrixXf* out) {
  const int d = static_cast<int>(refs.cols());
  const Eigen::Index nq = queries.rows();
  // Blocks of queries share each reference row while it is in cache.
  constexpr Eigen::Index kBlock = 16;
  for (Eigen::Index q0 = 0; q0 < nq; q0 += kBlock) {
    const Eigen::Index q1 = std::min(nq, q0 + kBlock);
    for (Eigen::Index r = r0; r < r1; ++r) {
      const float* ref = refs.row(r).data();
      const float rn = FixedOrderDot(ref, ref, d);
      for (Eigen::Index q = q0; q < q1; ++q) {
        const float dot = FixedOrderDot(queries.row(q).data(), ref, d);
        float& o = (*out)(q, r);
        if (metric == DistanceMetric::kEuclidean) {
          o = std::sqrt(std::max(qn(q) + rn - 2.0f * dot, 0.0f));
        } else {
          const float denom = std::sqrt(qn(q)) * std::sqrt(rn);
          o = denom > 0 ? std::max(1.0f - dot / denom, 0.0f) : 1.0f;
        }
      }
    }
  }
}

}  // namespace

void SetDistanceThreads(int n) { g_threads = std::max(0, n); }

int DistanceThreads() {
  const int n = g_threads.load();
  return n > 0 ? n : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const ReferenceSet& set) {
  CheckQueries(queries, set);
  const RowMatrixXf& refs = set.descriptors;
  const int d = static_cast<int>(refs.cols());
  const Eigen::Index nq = queries.rows(), nr = refs.rows();
  Eigen::VectorXf qn(nq);  // squared norms
  for (Eigen::Index q = 0; q < nq; ++q) {
    qn(q) = FixedOrderDot(queries.row(q).data(), queries.row(q).data(), d);
  }
  RowMatrixXf out(nq, nr);
  // Threads only pay off beyond about a million multiply-adds.
  const double work = static_cast<double>(nq) * static_cast<double>(nr) * d;
  const int threads =
      work < 1e6 ? 1 : static_cast<int>(std::min<Eigen::Index>(DistanceThreads(), nr));
  if (threads <= 1) {
    DistanceRows(metric, queries, refs, qn, 0, nr, &out);
    return out;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    const Eigen::Index r0 = nr * t / threads, r1 = nr * (t + 1) / threads;
    pool.emplace_back(DistanceRows, metric, std::cref(queries), std::cref(refs), std::cref(qn), r0,
                      r1, &out);
  }
  for (std::thread& th : pool) th.join();
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
