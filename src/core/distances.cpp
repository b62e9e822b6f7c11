#include "bsf_vpr/core/distances.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <thread>

#include "distance_kernels.h"

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

std::atomic<int> g_threads{0};  // 0: hardware concurrency

inline float DistanceFromDot(DistanceMetric metric, float qn, float rn, float dot) {
  if (metric == DistanceMetric::kEuclidean) return std::sqrt(std::max(qn + rn - 2.0f * dot, 0.0f));
  const float denom = std::sqrt(qn) * std::sqrt(rn);
  return denom > 0 ? std::max(1.0f - dot / denom, 0.0f) : 1.0f;
}

// Fills out(q, r) for every query and the reference rows [r0, r1): inner products by the
// fixed-order kernel, then the metric from them and the squared norms.
void DistanceRows(DistanceMetric metric, const RowMatrixXf& queries, const kernels::RefRows& refs,
                  const float* ref_norms, const Eigen::VectorXf& qn, int r0, int r1,
                  RowMatrixXf* out) {
  const int nr = static_cast<int>(out->cols());
  kernels::Dots(refs, r0, r1, queries.data(), static_cast<int>(queries.rows()),
                static_cast<int>(queries.cols()), out->data() + r0, nr);
  for (Eigen::Index q = 0; q < queries.rows(); ++q) {
    float* row = out->row(q).data();
    for (int r = r0; r < r1; ++r) row[r] = DistanceFromDot(metric, qn(q), ref_norms[r], row[r]);
  }
}

}  // namespace

void SetDistanceThreads(int n) { g_threads = std::max(0, n); }

int DistanceThreads() {
  const int n = g_threads.load();
  return n > 0 ? n : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

std::string DistanceKernel() { return kernels::Active(); }
void SetDistanceKernel(const std::string& name) { kernels::Force(name); }

RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const ReferenceSet& set) {
  CheckQueries(queries, set);
  // A set outside a map has no store yet: read its float32 rows and compute their norms.
  DescriptorStore local;
  if (!set.store.built()) local = MakeDescriptorStore(set.descriptors, StoragePrecision::kFloat32);
  const DescriptorStore& store = set.store.built() ? set.store : local;
  kernels::RefRows refs;
  refs.precision = store.precision;
  refs.cols = store.cols;
  refs.scale = store.scale;
  refs.data = store.precision == StoragePrecision::kFloat16 ? static_cast<const void*>(store.half.data())
              : store.precision == StoragePrecision::kInt8  ? static_cast<const void*>(store.int8.data())
                                                            : static_cast<const void*>(set.descriptors.data());
  const int d = store.cols, nr = store.rows;
  const Eigen::Index nq = queries.rows();
  Eigen::VectorXf qn(nq);  // squared norms
  for (Eigen::Index q = 0; q < nq; ++q) qn(q) = kernels::SelfDot(queries.row(q).data(), d);
  RowMatrixXf out(nq, nr);
  // Threads only pay off beyond about a million multiply-adds.
  const double work = static_cast<double>(nq) * static_cast<double>(nr) * d;
  const int threads = work < 1e6 ? 1 : std::min(DistanceThreads(), nr);
  const float* norms = store.squared_norms.data();
  if (threads <= 1) {
    DistanceRows(metric, queries, refs, norms, qn, 0, nr, &out);
    return out;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    const int r0 = static_cast<int>(static_cast<int64_t>(nr) * t / threads);
    const int r1 = static_cast<int>(static_cast<int64_t>(nr) * (t + 1) / threads);
    pool.emplace_back(DistanceRows, metric, std::cref(queries), std::cref(refs), norms,
                      std::cref(qn), r0, r1, &out);
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
