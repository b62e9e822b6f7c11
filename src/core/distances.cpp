#include "bsf_vpr/core/distances.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <thread>

#include "src/core/internal/distance_formula.h"
#include "src/core/internal/distance_kernels.h"
#include "src/core/internal/worker_pool.h"

namespace bsf_vpr {

const EnumNames<DistanceMetric>& DistanceMetricNames() {
  static const EnumNames<DistanceMetric> kNames{{DistanceMetric::kEuclidean, "euclidean"},
                                                {DistanceMetric::kCosine, "cosine"}};
  return kNames;
}

DistanceMetric ParseDistanceMetric(const std::string& name) {
  return DistanceMetricNames().Parse(name, "distance");
}

std::string ToString(DistanceMetric metric) { return DistanceMetricNames().Name(metric); }

namespace {

void CheckDimension(const RowMatrixXf& queries, const std::string& set_name, int dimension) {
  if (queries.cols() != dimension) {
    throw std::invalid_argument("query descriptors have dimension " +
                                std::to_string(queries.cols()) + ", reference set '" + set_name +
                                "' has dimension " + std::to_string(dimension));
  }
}

}  // namespace

void CheckQueryDescriptors(const RowMatrixXf& queries) {
  for (Eigen::Index q = 0; q < queries.rows(); ++q) {
    const std::string problem = DescriptorProblem(queries.row(q));
    if (!problem.empty()) {
      throw std::invalid_argument("query descriptor " + std::to_string(q) + " " + problem);
    }
  }
}

namespace {

std::atomic<int> g_threads{0};  // 0: hardware concurrency

// Fills out(q, r) for every query and the reference rows [r0, r1): inner products by the
// fixed-order kernel, then the metric from them and the squared norms.
void DistanceRows(DistanceMetric metric, const kernels::Queries& queries,
                  const kernels::RefRows& refs, const float* ref_norms, const Eigen::VectorXf& qn,
                  int r0, int r1, RowMatrixXf* out) {
  kernels::ToDistancesArgs finish;
  finish.metric = metric;
  finish.query_squared_norms = qn.data();
  finish.row_squared_norms = ref_norms;
  kernels::Dots(refs, r0, r1, queries, out->data() + r0, static_cast<int>(out->cols()), &finish);
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

// One set's rows as the kernels read them, with their squared norms.
struct SetRows {
  const std::string* name = nullptr;
  kernels::RefRows refs;
  int rows = 0;
  const float* norms = nullptr;  // `rows` entries
};

SetRows RowsOf(const StoredReferenceSet& set) {
  SetRows out;
  out.name = &set.name();
  out.refs.precision = set.precision();
  out.refs.data = set.data();
  out.refs.cols = set.dimension();
  out.refs.scale = set.scale();
  out.rows = set.size();
  out.norms = set.squared_norms().data();
  return out;
}

// One set's part of a distance computation: its rows, its output, its row ranges.
struct SetJob {
  SetRows set;
  RowMatrixXf out;
  int parts = 1;  // row ranges, one task each
};

void PrepareJob(const RowMatrixXf& queries, const SetRows& set, int threads, SetJob* job) {
  job->set = set;
  job->out.resize(queries.rows(), set.rows);
  // Threads only pay off beyond about a million multiply-adds. Four row ranges a thread,
  // so that a thread that finishes early (its rows read faster, or the other thread lost its
  // core a while) takes more, rather than wait for the other's last range.
  const double work = static_cast<double>(queries.rows()) * set.rows * set.refs.cols;
  const int per_thread = work < 1e8 ? 1 : 4;
  job->parts = work < 1e6 ? 1 : std::max(1, std::min(threads * per_thread, set.rows));
}

// Distances from `queries` to every set: all sets' row ranges as tasks of one parallel run
// on the worker pool.
std::vector<RowMatrixXf> ComputeAll(DistanceMetric metric, const RowMatrixXf& queries,
                                    const std::vector<SetRows>& sets) {
  for (const SetRows& set : sets) CheckDimension(queries, *set.name, set.refs.cols);
  CheckQueryDescriptors(queries);  // once, not per set
  const int threads = DistanceThreads();
  std::vector<SetJob> jobs(sets.size());
  std::vector<std::pair<size_t, int>> tasks;  // (set, part)
  bool int8_rows = false;
  for (size_t u = 0; u < sets.size(); ++u) {
    PrepareJob(queries, sets[u], threads, &jobs[u]);
    for (int t = 0; t < jobs[u].parts; ++t) tasks.emplace_back(u, t);
    int8_rows = int8_rows || sets[u].refs.precision == StoragePrecision::kInt8;
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
    DistanceRows(metric, prepared, job.set.refs, job.set.norms, qn, r0, r1, &job.out);
  });
  std::vector<RowMatrixXf> out;
  out.reserve(jobs.size());
  for (SetJob& job : jobs) out.push_back(std::move(job.out));
  return out;
}

}  // namespace

RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const StoredReferenceSet& set) {
  return std::move(ComputeAll(metric, queries, {RowsOf(set)}).front());
}

RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const ReferenceSet& set) {
  // The float32 rows as given, with their squared norms computed as a map computes them.
  const int rows = set.size(), cols = set.dimension();
  Eigen::VectorXf norms(rows);
  for (int r = 0; r < rows; ++r) norms(r) = kernels::SelfDot(set.descriptors.row(r).data(), cols);
  SetRows in;
  in.name = &set.name;
  in.refs.precision = StoragePrecision::kFloat32;
  in.refs.data = set.descriptors.data();
  in.refs.cols = cols;
  in.rows = rows;
  in.norms = norms.data();
  return std::move(ComputeAll(metric, queries, {in}).front());
}

std::vector<RowMatrixXf> ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                                          const ReferenceSets& map) {
  std::vector<SetRows> sets;
  for (const StoredReferenceSet& set : map.sets()) sets.push_back(RowsOf(set));
  return ComputeAll(metric, queries, sets);
}

std::vector<SetDistances> QueryRowViews(const std::vector<RowMatrixXf>& per_set, int query,
                                        const std::vector<const std::vector<int>*>& place_ids,
                                        const std::vector<int>& groups) {
  if (!groups.empty() && groups.size() != per_set.size()) {
    throw std::invalid_argument("QueryRowViews: " + std::to_string(groups.size()) +
                                " descriptor groups for " + std::to_string(per_set.size()) +
                                " sets");
  }
  std::vector<SetDistances> views(per_set.size());
  for (size_t u = 0; u < per_set.size(); ++u) {
    views[u].values = per_set[u].row(query).data();
    views[u].count = static_cast<int>(per_set[u].cols());
    views[u].place_ids = (u < place_ids.size() && place_ids[u]) ? place_ids[u]->data() : nullptr;
    views[u].group = u < groups.size() ? groups[u] : 0;
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
