#include "bsf_vpr/core/distances.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <thread>

#include "distance_kernels.h"
#include "worker_pool.h"

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

void CheckDimension(const RowMatrixXf& queries, const ReferenceSet& set) {
  if (queries.cols() != set.descriptors.cols()) {
    throw std::invalid_argument("query descriptors have dimension " +
                                std::to_string(queries.cols()) + ", reference set '" + set.name +
                                "' has dimension " + std::to_string(set.descriptors.cols()));
  }
}

void CheckFinite(const RowMatrixXf& queries) {
  for (Eigen::Index q = 0; q < queries.rows(); ++q) {
    const std::string problem = DescriptorProblem(queries.row(q));
    if (!problem.empty()) {
      throw std::invalid_argument("query descriptor " + std::to_string(q) + " " + problem);
    }
  }
}

}  // namespace

namespace {

std::atomic<int> g_threads{0};  // 0: hardware concurrency

// Fills out(q, r) for every query and the reference rows [r0, r1): inner products by the
// fixed-order kernel, then the metric from them and the squared norms (one loop per metric,
// without branches, so that the compiler vectorises the square roots).
void DistanceRows(DistanceMetric metric, const kernels::Queries& queries,
                  const kernels::RefRows& refs, const float* ref_norms, const Eigen::VectorXf& qn,
                  int r0, int r1, RowMatrixXf* out) {
  const int nr = static_cast<int>(out->cols());
  kernels::Dots(refs, r0, r1, queries, out->data() + r0, nr);
  for (Eigen::Index q = 0; q < out->rows(); ++q) {
    float* row = out->row(q).data();
    const float qq = qn(q);
    if (metric == DistanceMetric::kEuclidean) {
      for (int r = r0; r < r1; ++r) row[r] = std::sqrt(std::max(qq + ref_norms[r] - 2.0f * row[r], 0.0f));
    } else {
      const float q_norm = std::sqrt(qq);
      for (int r = r0; r < r1; ++r) {
        const float denom = q_norm * std::sqrt(ref_norms[r]);
        row[r] = denom > 0 ? std::max(1.0f - row[r] / denom, 0.0f) : 1.0f;
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

std::string DistanceKernel() { return kernels::Active(); }
void SetDistanceKernel(const std::string& name) { kernels::Force(name); }

namespace {

// One set's part of a distance computation: its store, its output, its row ranges.
struct SetJob {
  DescriptorStore local;  // for a set outside a map (no store yet): float32 norms
  kernels::RefRows refs;
  const float* norms = nullptr;
  RowMatrixXf out;
  int parts = 1;  // row ranges, one task each
};

void PrepareJob(const RowMatrixXf& queries, const ReferenceSet& set, int threads, SetJob* job) {
  if (!set.store.built()) job->local = MakeDescriptorStore(set.descriptors, StoragePrecision::kFloat32);
  const DescriptorStore& store = set.store.built() ? set.store : job->local;
  job->refs.precision = store.precision;
  job->refs.cols = store.cols;
  job->refs.scale = store.scale;
  job->refs.data = set.StoredData();  // the float32 matrix while the store is not built
  job->norms = store.squared_norms.data();
  job->out.resize(queries.rows(), store.rows);
  // Threads only pay off beyond about a million multiply-adds.
  const double work = static_cast<double>(queries.rows()) * store.rows * store.cols;
  job->parts = work < 1e6 ? 1 : std::max(1, std::min(threads, store.rows));
}

// Distances from `queries` to every set: all sets' row ranges as tasks of one parallel run
// on the worker pool.
std::vector<RowMatrixXf> ComputeAll(DistanceMetric metric, const RowMatrixXf& queries,
                                    const std::vector<const ReferenceSet*>& sets) {
  for (const ReferenceSet* set : sets) CheckDimension(queries, *set);
  CheckFinite(queries);  // once, not per set
  const int threads = DistanceThreads();
  std::vector<SetJob> jobs(sets.size());
  std::vector<std::pair<size_t, int>> tasks;  // (set, part)
  bool int8_rows = false;
  for (size_t u = 0; u < sets.size(); ++u) {
    PrepareJob(queries, *sets[u], threads, &jobs[u]);
    for (int t = 0; t < jobs[u].parts; ++t) tasks.emplace_back(u, t);
    int8_rows = int8_rows || jobs[u].refs.precision == StoragePrecision::kInt8;
  }
  // Once for every set and thread.
  const kernels::Queries prepared = kernels::PrepareQueries(
      queries.data(), static_cast<int>(queries.rows()), static_cast<int>(queries.cols()),
      static_cast<int>(queries.cols()), int8_rows);
  Eigen::VectorXf qn(queries.rows());  // squared norms
  for (Eigen::Index q = 0; q < queries.rows(); ++q) {
    qn(q) = kernels::SelfDot(queries.row(q).data(), static_cast<int>(queries.cols()));
  }
  RunParallel(static_cast<int>(tasks.size()), threads, [&](int i) {
    SetJob& job = jobs[tasks[static_cast<size_t>(i)].first];
    const int t = tasks[static_cast<size_t>(i)].second;
    const int nr = static_cast<int>(job.out.cols());
    const int r0 = static_cast<int>(static_cast<int64_t>(nr) * t / job.parts);
    const int r1 = static_cast<int>(static_cast<int64_t>(nr) * (t + 1) / job.parts);
    DistanceRows(metric, prepared, job.refs, job.norms, qn, r0, r1, &job.out);
  });
  std::vector<RowMatrixXf> out;
  out.reserve(jobs.size());
  for (SetJob& job : jobs) out.push_back(std::move(job.out));
  return out;
}

}  // namespace

RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const ReferenceSet& set) {
  return std::move(ComputeAll(metric, queries, {&set}).front());
}

std::vector<RowMatrixXf> ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                                          const ReferenceMap& map) {
  std::vector<const ReferenceSet*> sets;
  for (const ReferenceSet& set : map.sets()) sets.push_back(&set);
  return ComputeAll(metric, queries, sets);
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
