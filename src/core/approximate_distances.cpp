// GCC 12 warns that Eigen's tridiagonalisation (SelfAdjointEigenSolver) may read `result`
// uninitialised, a false positive in Eigen/Core's products; the warning follows the location
// of their definition, so it is turned off around the includes (not for this file's code).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include "bsf_vpr/core/approximate_distances.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <queue>
#include <random>
#include <stdexcept>
#include <unordered_set>
#include <utility>

#include "src/core/internal/distance_formula.h"
#include "src/core/internal/distance_kernels.h"
#include "src/core/internal/worker_pool.h"
#pragma GCC diagnostic pop

namespace bsf_vpr {

void ApproximateOptions::Validate() const {
  // The options' bounds, named by this struct's fields: the index is built in code (the
  // benchmarks, the tests) under these names as well as from parameters.
  const OptionTable<ApproximateOptions>& table = ApproximateOptionsTable();
  table.CheckValue(*this, "first_stage_dimensions", "ApproximateOptions.dimensions");
  table.CheckValue(*this, "rerank_candidates", "ApproximateOptions.rerank");
  table.CheckValue(*this, "first_stage_sample_rows", "ApproximateOptions.sample_rows");
}

const OptionTable<ApproximateOptions>& ApproximateOptionsTable() {
  static const OptionTable<ApproximateOptions> kTable =
      OptionTable<ApproximateOptions>()
          .Add(
              "first_stage_dimensions", [](auto& o) -> auto& { return o.dimensions; },
              "pca: projected dimensions d' (bytes per row the first stage reads)", "dimensions",
              AtLeast(1))
          .Add(
              "rerank_candidates", [](auto& o) -> auto& { return o.rerank; },
              "pca: rows per set and query whose distance is made exact (the nearest by the "
              "approximate distance)",
              "rows", AtLeast(0))
          .Add(
              "first_stage_sample_rows", [](auto& o) -> auto& { return o.sample_rows; },
              "pca: rows drawn from the map to fit the basis (fitting costs O(rows^2 D + rows^3): "
              "about 3.5 s for 2048 rows of 4096-d on 2 cores, 8x that per doubling)",
              "rows", Between(1, ApproximateOptions::kMaxSampleRows));
  return kTable;
}

namespace {

// Eigenvalues of the sample's Gram matrix below this fraction of the largest are taken for
// rounding noise (the Gram matrix is summed in float): their directions are not used.
constexpr float kRankTolerance = 1e-5f;
// Rows of one task of the first stage and of the projection of a set.
constexpr int kStageRows = 8192;
constexpr int kProjectRows = 512;

kernels::RefRows FloatRows(const float* data, int cols) {
  kernels::RefRows rows;
  rows.data = data;
  rows.cols = cols;
  return rows;
}

kernels::RefRows StoredRows(const StoredReferenceSet& set) {
  kernels::RefRows rows;
  rows.precision = set.precision();
  rows.data = set.data();
  rows.cols = set.dimension();
  rows.scale = set.scale();
  return rows;
}

// Parts of [0, rows) of at most `per_part` rows: part t is [Begin(t), Begin(t + 1)).
struct Split {
  int rows = 0, parts = 1;
  Split(int rows_in, int per_part)
      : rows(rows_in), parts(std::max(1, (rows_in + per_part - 1) / per_part)) {}
  int Begin(int t) const { return static_cast<int>(static_cast<int64_t>(rows) * t / parts); }
};

// out[q * out_stride + r] = <query q, row r> for the rows [0, rows), on the worker pool.
void ParallelDots(const kernels::RefRows& refs, int rows, const kernels::Queries& queries,
                  float* out, int out_stride, int threads) {
  const Split split(rows, 256);
  RunParallel(split.parts, threads, [&](int t) {
    const int r0 = split.Begin(t), r1 = split.Begin(t + 1);
    kernels::Dots(refs, r0, r1, queries, out + r0, out_stride);
  });
}

// FNV-1a over a set's scale and the bits of the squared norms of up to 64 rows spread over
// it: a set replaced by another of the same name and size almost surely changes it.
uint64_t Fingerprint(const StoredReferenceSet& set) {
  uint64_t h = 1469598103934665603ull;
  const auto mix = [&h](float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    for (int b = 0; b < 4; ++b) h = (h ^ ((bits >> (8 * b)) & 0xff)) * 1099511628211ull;
  };
  mix(set.scale());
  const int n = set.size(), samples = std::min(n, 64);
  for (int k = 0; k < samples; ++k) {
    const int r =
        samples > 1 ? static_cast<int>(static_cast<int64_t>(n - 1) * k / (samples - 1)) : 0;
    mix(set.squared_norms()(r));
  }
  return h;
}

// `count` distinct indices of [0, total), ascending (all of them if count >= total).
std::vector<int64_t> SampleIndices(int64_t total, int64_t count, uint64_t seed) {
  std::vector<int64_t> out;
  if (count >= total) {
    for (int64_t i = 0; i < total; ++i) out.push_back(i);
    return out;
  }
  // Floyd's algorithm: count draws, each adding one index.
  std::mt19937_64 rng(seed);
  std::unordered_set<int64_t> chosen;
  for (int64_t j = total - count; j < total; ++j) {
    const int64_t t = std::uniform_int_distribution<int64_t>(0, j)(rng);
    chosen.insert(chosen.count(t) ? j : t);
  }
  out.assign(chosen.begin(), chosen.end());
  std::sort(out.begin(), out.end());
  return out;
}

// The rows of `sets` at the given global indices (sets in order, rows in order), decoded.
RowMatrixXf DecodeRows(const std::vector<StoredReferenceSet>& sets,
                       const std::vector<int64_t>& indices) {
  RowMatrixXf x(static_cast<Eigen::Index>(indices.size()), sets.front().dimension());
  size_t u = 0;
  int64_t first = 0;  // global index of set u's row 0
  for (size_t i = 0; i < indices.size(); ++i) {
    while (indices[i] >= first + sets[u].size()) first += sets[u++].size();
    sets[u].DecodeRow(static_cast<int>(indices[i] - first),
                      x.row(static_cast<Eigen::Index>(i)).data());
  }
  return x;
}

// Indices of the k smallest of values[0, n), ordered by (value, index): ties go to the lower
// index, so that the choice is the same however the rows were computed.
void SmallestRows(const float* values, int n, int k, std::vector<int>* rows) {
  rows->clear();
  if (k >= n) {
    for (int r = 0; r < n; ++r) rows->push_back(r);
    return;
  }
  if (k <= 0) return;
  std::priority_queue<std::pair<float, int>> largest_kept;  // top: the one to drop next
  for (int r = 0; r < k; ++r) largest_kept.emplace(values[r], r);
  for (int r = k; r < n; ++r) {
    // A later row with an equal value loses to the kept ones (its index is larger).
    if (values[r] < largest_kept.top().first) {
      largest_kept.pop();
      largest_kept.emplace(values[r], r);
    }
  }
  for (; !largest_kept.empty(); largest_kept.pop()) rows->push_back(largest_kept.top().second);
  std::sort(rows->begin(), rows->end());  // the map's rows in memory order
}

}  // namespace

ApproximateIndex::ApproximateIndex(const ReferenceSets& map, const ApproximateOptions& options)
    : ApproximateIndex(map.sets(), options, DistanceThreads()) {}

ApproximateIndex::ApproximateIndex(const std::vector<StoredReferenceSet>& sets,
                                   const ApproximateOptions& options, int threads)
    : options_(options), threads_(std::max(1, threads)) {
  options_.Validate();
  if (sets.empty()) throw std::invalid_argument("ApproximateIndex: the map holds no sets");
  dimension_ = sets.front().dimension();
  FitBasis(sets);
  sets_.reserve(sets.size());
  for (const StoredReferenceSet& set : sets) {
    sets_.push_back(std::make_shared<const SetCodes>(ProjectSet(set)));
  }
}

ApproximateIndex::ApproximateIndex(const ApproximateIndex& base,
                                   const std::vector<StoredReferenceSet>& sets, int threads)
    : options_(base.options_),
      threads_(std::max(1, threads)),
      dimension_(base.dimension_),
      dimensions_(base.dimensions_),
      sample_rows_(base.sample_rows_),
      basis_(base.basis_) {
  sets_.reserve(sets.size());
  for (const StoredReferenceSet& set : sets) {
    if (set.dimension() != dimension_) {
      throw std::invalid_argument("ApproximateIndex: set '" + set.name() + "' has dimension " +
                                  std::to_string(set.dimension()) + ", the basis " +
                                  std::to_string(dimension_));
    }
    const SetCodes* held = base.CodesOf(set);
    const auto same = std::find_if(base.sets_.begin(), base.sets_.end(),
                                   [held](const auto& codes) { return codes.get() == held; });
    sets_.push_back(held ? *same : std::make_shared<const SetCodes>(ProjectSet(set)));
  }
}

// Uncentred PCA of the sample X (S x D) through its Gram matrix G = X X^T (S x S): an
// eigenpair (lambda, v) of G gives the right singular vector X^T v / sqrt(lambda) of X.
void ApproximateIndex::FitBasis(const std::vector<StoredReferenceSet>& sets) {
  int64_t total = 0;
  for (const StoredReferenceSet& set : sets) total += set.size();
  const RowMatrixXf x = DecodeRows(sets, SampleIndices(total, options_.sample_rows, options_.seed));
  const int s = static_cast<int>(x.rows()), d = dimension_;
  sample_rows_ = s;
  RowMatrixXf gram(s, s);
  ParallelDots(FloatRows(x.data(), d), s, kernels::PrepareQueries(x.data(), s, d, d, false),
               gram.data(), s, threads_);
  // Single precision: the Gram matrix is summed in float anyway, and double takes 3x longer
  // (8.7 s for 2048 rows on the project's machine).
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXf> solver(gram);
  const Eigen::VectorXf& lambda = solver.eigenvalues();  // ascending
  const float largest = lambda(s - 1);
  int k = 0;
  // At most D directions: past the rows' rank the eigenvalues are rounding noise.
  const int most = std::min({options_.dimensions, s, d});
  while (k < most && lambda(s - 1 - k) > kRankTolerance * largest) ++k;
  dimensions_ = std::max(k, 1);  // an all-zero sample keeps one zero direction
  // Row j of `weights` is v_j / sqrt(lambda_j) (zero past the rank); basis row j is then
  // <weights_j, column i of X> for every i, a product of the kernels with X transposed.
  RowMatrixXf weights = RowMatrixXf::Zero(dimensions_, s);
  for (int j = 0; j < k; ++j) {
    weights.row(j) =
        solver.eigenvectors().col(s - 1 - j).transpose() / std::sqrt(lambda(s - 1 - j));
  }
  const RowMatrixXf xt = x.transpose();
  basis_.resize(dimensions_, d);
  ParallelDots(FloatRows(xt.data(), s), d,
               kernels::PrepareQueries(weights.data(), dimensions_, s, s, false), basis_.data(), d,
               threads_);
}

ApproximateIndex::SetCodes ApproximateIndex::ProjectSet(const StoredReferenceSet& set) const {
  SetCodes out;
  out.name = set.name();
  out.rows = set.size();
  out.precision = set.precision();
  out.fingerprint = Fingerprint(set);
  const int n = set.size(), dp = dimensions_;
  out.codes.resize(static_cast<size_t>(n) * dp);
  out.row_scales.resize(static_cast<size_t>(n));
  const kernels::Queries directions = kernels::PrepareQueries(
      basis_.data(), dp, dimension_, dimension_, set.precision() == StoragePrecision::kInt8);
  const kernels::RefRows rows = StoredRows(set);
  const Split split(n, kProjectRows);
  std::vector<double> part_energy(static_cast<size_t>(split.parts), 0.0);
  RunParallel(split.parts, threads_, [&](int t) {
    const int r0 = split.Begin(t), r1 = split.Begin(t + 1), m = r1 - r0;
    std::vector<float> coords(static_cast<size_t>(dp) *
                              m);  // coordinate j of row r0 + i at j m + i
    kernels::Dots(rows, r0, r1, directions, coords.data(), m);
    // Loops along the rows (contiguous in `coords`): the scale of each row, then its codes.
    std::vector<float> max_abs(static_cast<size_t>(m), 0.0f), inverse(static_cast<size_t>(m));
    double energy = 0;
    for (int j = 0; j < dp; ++j) {
      for (int i = 0; i < m; ++i) {
        max_abs[i] = std::max(max_abs[i], std::fabs(coords[j * m + i]));
        energy += static_cast<double>(coords[j * m + i]) * coords[j * m + i];
      }
    }
    part_energy[static_cast<size_t>(t)] = energy;
    for (int i = 0; i < m; ++i) {
      out.row_scales[static_cast<size_t>(r0 + i)] = max_abs[i] / 127.0f;
      inverse[i] = max_abs[i] > 0 ? 127.0f / max_abs[i] : 0.0f;
    }
    int8_t* codes = out.codes.data() + static_cast<size_t>(r0) * dp;
    for (int j = 0; j < dp; ++j) {
      for (int i = 0; i < m; ++i) {
        codes[static_cast<size_t>(i) * dp + j] =
            static_cast<int8_t>(std::nearbyint(coords[j * m + i] * inverse[i]));
      }
    }
  });
  // Summed in the parts' order: the same figure on any number of threads.
  for (const double e : part_energy) out.projected_energy += e;
  for (int r = 0; r < n; ++r) out.energy += set.squared_norms()(r);
  return out;
}

int64_t ApproximateIndex::rows() const {
  int64_t n = 0;
  for (const auto& c : sets_) n += c->rows;
  return n;
}

double ApproximateIndex::RetainedEnergy() const {
  double projected = 0, energy = 0;
  for (const auto& c : sets_) {
    projected += c->projected_energy;
    energy += c->energy;
  }
  return energy > 0 ? std::min(1.0, projected / energy) : 1.0;
}

double ApproximateIndex::RetainedEnergyOf(const StoredReferenceSet& set) const {
  const SetCodes* c = CodesOf(set);
  if (!c) return -1;
  return c->energy > 0 ? std::min(1.0, c->projected_energy / c->energy) : 1.0;
}

const ApproximateIndex::SetCodes* ApproximateIndex::CodesOf(const StoredReferenceSet& set) const {
  for (const auto& c : sets_) {
    if (c->name == set.name() && c->rows == set.size() && c->precision == set.precision() &&
        set.dimension() == dimension_ && c->fingerprint == Fingerprint(set)) {
      return c.get();
    }
  }
  return nullptr;
}

std::string ApproximateIndex::Missing(const StoredReferenceSet& set) const {
  std::string why = "set '" + set.name() + "' is not in the index";
  for (const auto& c : sets_) {
    if (c->name != set.name()) continue;
    why = "set '" + set.name() + "' changed: " + std::to_string(set.size()) + " rows at " +
          ToString(set.precision()) + ", was " + std::to_string(c->rows) + " at " +
          ToString(c->precision);
  }
  return "ApproximateIndex: the map is not the one the index was built from (" + why +
         "); build the index again, or extend it";
}

RowMatrixXf ApproximateIndex::ProjectQueries(const RowMatrixXf& queries) const {
  const int nq = static_cast<int>(queries.rows());
  RowMatrixXf out(nq, dimensions_);
  ParallelDots(FloatRows(basis_.data(), dimension_), dimensions_,
               kernels::PrepareQueries(queries.data(), nq, dimension_, dimension_, false),
               out.data(), dimensions_, DistanceThreads());
  return out;
}

std::vector<RowMatrixXf> ApproximateIndex::Distances(DistanceMetric metric,
                                                     const RowMatrixXf& queries,
                                                     const ReferenceSets& map, StageTimes* times,
                                                     std::vector<bool>* covered) const {
  using Clock = std::chrono::steady_clock;
  const auto ms = [](Clock::time_point from) {
    return std::chrono::duration<double, std::milli>(Clock::now() - from).count();
  };
  const int num_sets = map.num_sets();
  std::vector<const SetCodes*> codes(static_cast<size_t>(num_sets));
  if (covered) covered->assign(static_cast<size_t>(num_sets), false);
  for (int u = 0; u < num_sets; ++u) {
    codes[static_cast<size_t>(u)] = CodesOf(map.set(u));
    if (!codes[static_cast<size_t>(u)] && !covered) {
      throw std::invalid_argument(Missing(map.set(u)));
    }
    if (covered) (*covered)[static_cast<size_t>(u)] = codes[static_cast<size_t>(u)] != nullptr;
  }
  if (queries.cols() != dimension_) {
    throw std::invalid_argument("query descriptors have dimension " +
                                std::to_string(queries.cols()) + ", reference set '" +
                                (num_sets ? map.set(0).name() : sets_.front()->name) +
                                "' has dimension " + std::to_string(dimension_));
  }
  CheckQueryDescriptors(queries);
  const int nq = static_cast<int>(queries.rows());
  Eigen::VectorXf qn(nq);  // squared norms, as ComputeDistances computes them
  for (int q = 0; q < nq; ++q) qn(q) = kernels::SelfDot(queries.row(q).data(), dimension_);
  std::vector<RowMatrixXf> out(static_cast<size_t>(num_sets));
  for (int u = 0; u < num_sets; ++u) {
    if (codes[static_cast<size_t>(u)]) out[static_cast<size_t>(u)].resize(nq, map.set(u).size());
  }
  const auto start = Clock::now();
  ApproximateStage(metric, queries, qn, map, codes, &out);
  const double approximate_ms = ms(start);
  const auto rerank = Clock::now();
  if (options_.rerank > 0) ExactStage(metric, queries, qn, map, codes, &out);
  if (times != nullptr) *times = {approximate_ms, ms(rerank)};
  return out;
}

void ApproximateIndex::ApproximateStage(DistanceMetric metric, const RowMatrixXf& queries,
                                        const Eigen::VectorXf& qn, const ReferenceSets& map,
                                        const std::vector<const SetCodes*>& codes_of,
                                        std::vector<RowMatrixXf>* out) const {
  const int nq = static_cast<int>(queries.rows());
  const RowMatrixXf projected = ProjectQueries(queries);
  const kernels::Queries prepared =
      kernels::PrepareQueries(projected.data(), nq, dimensions_, dimensions_, true);
  // Parts of every answered set's rows as the tasks of one parallel run.
  std::vector<Split> splits;
  std::vector<std::pair<size_t, int>> tasks;  // (set, part)
  for (size_t u = 0; u < codes_of.size(); ++u) {
    splits.emplace_back(codes_of[u] ? codes_of[u]->rows : 0, kStageRows);
    if (!codes_of[u]) continue;
    for (int t = 0; t < splits.back().parts; ++t) tasks.emplace_back(u, t);
  }
  RunParallel(static_cast<int>(tasks.size()), DistanceThreads(), [&](int i) {
    const auto [u, t] = tasks[static_cast<size_t>(i)];
    const SetCodes& set = *codes_of[u];
    const int r0 = splits[u].Begin(t), r1 = splits[u].Begin(t + 1);
    kernels::RefRows codes;
    codes.precision = StoragePrecision::kInt8;
    codes.data = set.codes.data();
    codes.cols = dimensions_;
    RowMatrixXf& dist = (*out)[u];
    kernels::Dots(codes, r0, r1, prepared, dist.data() + r0, set.rows);
    const float* norms = map.set(static_cast<int>(u)).squared_norms().data();
    for (int q = 0; q < nq; ++q) {
      float* row = dist.row(q).data();
      for (int r = r0; r < r1; ++r) row[r] *= set.row_scales[static_cast<size_t>(r)];
      formula::ToDistances(metric, qn(q), norms, r0, r1, row);
    }
  });
}

// The kernels and formula of ComputeDistances on the candidate rows; each query prepared
// alone gives the bits it has in a batch (distance_kernels.h).
void ApproximateIndex::ExactStage(DistanceMetric metric, const RowMatrixXf& queries,
                                  const Eigen::VectorXf& qn, const ReferenceSets& map,
                                  const std::vector<const SetCodes*>& codes_of,
                                  std::vector<RowMatrixXf>* out) const {
  const int nq = static_cast<int>(queries.rows());
  bool int8_rows = false;
  for (const StoredReferenceSet& set : map.sets()) {
    int8_rows = int8_rows || set.precision() == StoragePrecision::kInt8;
  }
  std::vector<int> answered;  // the sets with codes
  for (size_t u = 0; u < codes_of.size(); ++u) {
    if (codes_of[u]) answered.push_back(static_cast<int>(u));
  }
  std::vector<kernels::Queries> prepared;
  prepared.reserve(static_cast<size_t>(nq));
  for (int q = 0; q < nq; ++q) {
    prepared.push_back(
        kernels::PrepareQueries(queries.row(q).data(), 1, dimension_, dimension_, int8_rows));
  }
  const int num_sets = static_cast<int>(answered.size());
  RunParallel(num_sets * nq, DistanceThreads(), [&](int i) {
    const int u = answered[static_cast<size_t>(i % num_sets)], q = i / num_sets;
    const StoredReferenceSet& set = map.set(u);
    const kernels::RefRows rows = StoredRows(set);
    float* row = (*out)[static_cast<size_t>(u)].row(q).data();
    std::vector<int> candidates;
    SmallestRows(row, set.size(), options_.rerank, &candidates);
    // The candidates lie anywhere in the set: each row is asked of memory while the one
    // before it is computed, so that the loads overlap the arithmetic.
    const size_t row_bytes = static_cast<size_t>(rows.cols) * BytesPerElement(rows.precision);
    const auto prefetch = [&](int r) {
      const char* at = static_cast<const char*>(rows.data) + static_cast<size_t>(r) * row_bytes;
      for (size_t b = 0; b < row_bytes; b += 64) __builtin_prefetch(at + b);
    };
    if (!candidates.empty()) prefetch(candidates.front());
    for (size_t k = 0; k < candidates.size(); ++k) {
      const int r = candidates[k];
      if (k + 1 < candidates.size()) prefetch(candidates[k + 1]);
      kernels::Dots(rows, r, r + 1, prepared[static_cast<size_t>(q)], row + r, 1);
      formula::ToDistances(metric, qn(q), set.squared_norms().data(), r, r + 1, row);
    }
  });
}

size_t ApproximateIndex::MemoryBytes() const {
  size_t bytes = sizeof(*this) + sizeof(float) * basis_.size();
  for (const auto& set : sets_) {
    bytes += sizeof(SetCodes) + set->name.capacity() + set->codes.capacity() +
             sizeof(float) * set->row_scales.capacity();
  }
  return bytes;
}

}  // namespace bsf_vpr
