// Approximate query-to-reference distances for maps too large to search exactly at camera
// rate (e.g. 10 sets of 100,000 places of 4096-D descriptors: exact search streams 4-16 GB
// per query).
//
// A compressed first stage gives an approximate distance from every query to EVERY row of
// every set (the fusion needs all of them: the selection takes each set's minimum, the
// likelihood rank counts and the mean and spread of all distances); then the `rerank`
// smallest of each set and query are replaced by their exact distances. The first stage
// projects queries and rows onto an uncentred PCA basis of d' dimensions fitted to a sample
// of the map's rows (the rows' projections held as int8, a few hundred bytes a row) and
// takes the distance from the approximate inner product <Pq, Pr> with the EXACT squared
// norms: Euclidean sqrt(max(||q||^2 + ||r||^2 - 2 <Pq, Pr>, 0)), cosine
// 1 - <Pq, Pr> / (||q|| ||r||), the formulas of ComputeDistances (distances.h), whose
// distances are not squared either.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/core/distance_index.h"
#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

struct ApproximateOptions {
  // Projected dimensions d' of the first stage (bytes per row and query it streams); capped
  // at the numerical rank of the sample.
  int dimensions = 256;
  // Rows per set and query whose distance is made exact (0: all approximate; >= N_u: the
  // set's distances are exactly ComputeDistances'). 1000 is 1% of a 100,000-place set: on
  // the real data, re-ranking 1% of the rows kept R@1 within 0.2 points of exact search,
  // 0.1% within 0.8 (docs/performance.md); the nearest places fall outside the candidates in
  // proportion to the rows, so the count should grow with the map.
  int rerank = 1000;
  // Rows drawn at random from all sets of the map (without replacement; all rows when the
  // map holds fewer) to fit the basis. Fitting costs O(sample_rows^2 D + sample_rows^3).
  int sample_rows = 2048;
  uint64_t seed = 0;  // of the sample
  // The fit holds a sample_rows^2 Gram matrix (256 MB at this bound) and solves it in
  // O(sample_rows^3): beyond it a fit would take hours.
  static constexpr int kMaxSampleRows = 8192;

  // Throws std::invalid_argument naming the field ("ApproximateOptions.dimensions") for a
  // value out of the bounds of ApproximateOptionsTable: dimensions < 1, rerank < 0,
  // sample_rows < 1 or > kMaxSampleRows.
  void Validate() const;
};

// first_stage_dimensions, rerank_candidates and first_stage_sample_rows (part of
// FirstStageOptionsTable, first_stage.h); seed is not an option.
const OptionTable<ApproximateOptions>& ApproximateOptionsTable();

// The first stage's data for a map's sets: the basis and every row's projection (a set's
// codes). Built once for a map (see the constructor for its cost); it answers for any map
// whose sets it holds codes of (by name, size, precision and fingerprint: a set replaced
// under the same name is another set). A map that gained a set is answered by an index
// extended with that set's codes (the extending constructor: the basis kept, only the new
// rows projected). Immutable once built; Distances may be called from several threads.
class ApproximateIndex final : public DistanceIndex {
 public:
  // Fits the basis to a sample of `map`'s rows (decoded as stored) and projects every row
  // of every set. Threads: DistanceThreads(). Throws std::invalid_argument if the options
  // are invalid or the map holds no sets. `map` is not referenced after it returns.
  ApproximateIndex(const ReferenceSets& map, const ApproximateOptions& options = {});
  // The same for `sets` (one dimension), on `threads` threads: 1 runs on the caller's
  // thread alone, without the worker pool that queries use (a build in the background).
  ApproximateIndex(const std::vector<StoredReferenceSet>& sets, const ApproximateOptions& options,
                   int threads);
  // `base` for `sets`: its basis and options, its codes of the sets it holds, and the
  // projections of the others (an incremental build: a recorded or loaded set costs its own
  // rows). Codes of sets not in `sets` are dropped. Throws std::invalid_argument if the
  // dimension differs from the basis'.
  ApproximateIndex(const ApproximateIndex& base, const std::vector<StoredReferenceSet>& sets,
                   int threads);

  // Distances from each of the Q queries (rows of `queries`, Q x D) to every row of every
  // set of `map`: element u is Q x N_u, as ComputeDistances(metric, queries, map) gives
  // (not squared). Each set's `rerank` smallest approximate distances per query (ties to
  // the lower row) are replaced by exact ones, bitwise those ComputeDistances computes; the
  // rest are approximate. Results do not depend on the thread count.
  // Throws std::invalid_argument if the dimensions differ, a query holds NaN/infinity, or
  // a set of `map` has no codes here (added, or replaced, since the index was built) and
  // `covered` is null. With `covered`, such a set is left out instead: its element is empty
  // and (*covered)[u] false (true for the sets answered).
  // `times`, if given, receives the wall time of each stage.
  struct StageTimes {
    double approximate_ms = 0;  // the projections' distances to every row
    double rerank_ms = 0;       // the candidates' exact distances
  };
  std::vector<RowMatrixXf> Distances(DistanceMetric metric, const RowMatrixXf& queries,
                                     const ReferenceSets& map, StageTimes* times = nullptr,
                                     std::vector<bool>* covered = nullptr) const;
  // Distances without the stage times (DistanceIndex).
  std::vector<RowMatrixXf> Search(DistanceMetric metric, const RowMatrixXf& queries,
                                  const ReferenceSets& sets,
                                  std::vector<bool>* covered) const override {
    return Distances(metric, queries, sets, nullptr, covered);
  }
  // Whether the index holds codes of `set` (Distances answers for it).
  bool Covers(const StoredReferenceSet& set) const { return CodesOf(set) != nullptr; }
  // The share of `set`'s rows' energy the basis keeps (as RetainedEnergy), if it holds its
  // codes; -1 otherwise.
  double RetainedEnergyOf(const StoredReferenceSet& set) const;

  const ApproximateOptions& options() const { return options_; }
  int dimensions() const { return dimensions_; }    // d' in use (options' capped at the rank)
  int sample_rows() const { return sample_rows_; }  // rows the basis was fitted to
  int64_t rows() const;                             // rows projected, over every set
  // The share of the rows' squared norms that their projections keep, over every row of
  // every set: sum ||P r||^2 / sum ||r||^2, in [0, 1]. The first stage's error on a row is
  // |<q, r> - <Pq, Pr>| <= ||q|| ||r|| sqrt(1 - ||P r||^2 / ||r||^2), whatever the query, so
  // this says how well the basis fits the map: near 1 the approximate distances are nearly
  // exact; well below it (descriptors with more structure than d' directions, or a sample
  // too small for the map) the nearest places may fall outside the re-ranked candidates.
  double RetainedEnergy() const;
  // Bytes held: the basis and the rows' projections.
  size_t MemoryBytes() const;

 private:
  // One set's rows projected: row r's coordinate j is codes[r d' + j] x row_scales[r]
  // (int8 with one scale per row: on the shipped real data its rounding adds about 2% to the
  // error that dropping the trailing dimensions makes, so float16 would double the bytes for
  // nothing).
  struct SetCodes {
    std::string name;
    int rows = 0;
    StoragePrecision precision = StoragePrecision::kFloat32;
    uint64_t fingerprint = 0;  // of the set's scale and the squared norms of 64 of its rows
    std::vector<int8_t> codes;
    std::vector<float> row_scales;
    double projected_energy = 0;  // sum over the rows of ||P r||^2 (before rounding)
    double energy = 0;            // sum over the rows of ||r||^2
  };

  void FitBasis(const std::vector<StoredReferenceSet>& sets);
  SetCodes ProjectSet(const StoredReferenceSet& set) const;
  // The codes of `set`, or null.
  const SetCodes* CodesOf(const StoredReferenceSet& set) const;
  // Why the index has no codes of `set` (for Distances' refusal).
  std::string Missing(const StoredReferenceSet& set) const;
  // Projections of the queries onto the basis: Q x d'.
  RowMatrixXf ProjectQueries(const RowMatrixXf& queries) const;
  // ApproximateStage fills `out` (Q x N_u per set) with approximate distances, ExactStage
  // then overwrites each set's `rerank` smallest per query. `qn`: the queries' squared norms.
  // `codes[u]` is set u's codes (null: set u is left out).
  void ApproximateStage(DistanceMetric metric, const RowMatrixXf& queries,
                        const Eigen::VectorXf& qn, const ReferenceSets& map,
                        const std::vector<const SetCodes*>& codes,
                        std::vector<RowMatrixXf>* out) const;
  void ExactStage(DistanceMetric metric, const RowMatrixXf& queries, const Eigen::VectorXf& qn,
                  const ReferenceSets& map, const std::vector<const SetCodes*>& codes,
                  std::vector<RowMatrixXf>* out) const;

  ApproximateOptions options_;
  int threads_ = 1;     // of a build (Distances uses DistanceThreads())
  int dimension_ = 0;   // D
  int dimensions_ = 0;  // d'
  int sample_rows_ = 0;
  RowMatrixXf basis_;  // d' x D, orthonormal rows (the top right singular vectors)
  // Shared with the indexes extended from this one (they are immutable).
  std::vector<std::shared_ptr<const SetCodes>> sets_;
};

}  // namespace bsf_vpr
