// Query-to-reference descriptor distances (the vectors D^u of the paper, Sec. III-A).
//
// All distances returned here are NOT squared: Euclidean is ||q - r||_2 (the paper's), and
// cosine is 1 - <q, r> / (||q|| ||r||), in [0, 2]. A zero-norm vector has cosine
// similarity 0 to everything (distance 1), never NaN; a query of zeros is refused before
// it is recognised (ReferenceSets::CheckQuery). Both are non-negative.
#pragma once

#include <string>
#include <vector>

#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

enum class DistanceMetric { kEuclidean, kCosine };

// The metrics' names (the distance of parameters, flags and reference-set files).
const EnumNames<DistanceMetric>& DistanceMetricNames();
// A name of DistanceMetricNames(); throws std::invalid_argument naming the choices otherwise.
DistanceMetric ParseDistanceMetric(const std::string& name);
std::string ToString(DistanceMetric metric);

// Distances from one query to the places one reference set covers: a view on caller-owned
// memory. values[k] is the (non-squared, >= 0) distance to place place_ids[k]; a null
// place_ids means values[k] is the distance to place k.
struct SetDistances {
  const float* values = nullptr;
  const int* place_ids = nullptr;
  int count = 0;
  // Sets of one group hold distances of one descriptor, on one scale (reference sets compared
  // with the same query descriptor); sets of different groups come from different
  // descriptors (precomputed matrices of several techniques). Selection compares minimum
  // distances only within a group, and the mixture fusion mixes within a group and
  // multiplies across groups.
  int group = 0;

  int PlaceAt(int k) const { return place_ids ? place_ids[k] : k; }
};

// Threads used by ComputeDistances when the work is large enough (default: the machine's
// cores). Results are bitwise the same for any count: threads split the reference rows and
// every distance is computed by the same fixed-order inner product. Process-wide; n < 1
// restores the default.
void SetDistanceThreads(int n);
int DistanceThreads();

// The inner-product kernel in use, one source compiled for each instruction set (Google
// Highway) and chosen at run time as the best the CPU runs: "avx512_vnni" (Highway's AVX3_DL:
// AVX-512 with VNNI, the int8 rows' integer products 32 an instruction), "avx512" (AVX3:
// AVX-512 F, VL, DQ, BW), "avx2" (AVX2 + FMA + F16C), "neon" (aarch64), or "portable".
// SetDistanceKernel(one of them | "auto") overrides the choice for the process (tests,
// benchmarks); throws std::invalid_argument for an unknown name or if the CPU cannot run it.
// "avx512_vnni", "avx512", "avx2" and "neon" give the same bits (the same order and FMA;
// AVX-512 batches two queries to a register, or from 32 queries one lane at a time);
// "portable" differs from them in the last bits of float32 and float16 rows. int8 rows are
// summed exactly in integers: the same bits on every kernel.
std::string DistanceKernel();
void SetDistanceKernel(const std::string& name);

// Distances from each of the Q queries (rows of `queries`, Q x D) to each of the N_u
// descriptors of `set`; returns Q x N_u. Euclidean is sqrt(max(||q||^2 + ||r||^2 - 2 q.r,
// 0)) and cosine 1 - q.r / (||q|| ||r||), from inner products summed in one fixed order
// (blocked over queries and rows, threads over rows) against the set's rows as stored:
// float32, float16 or int8 as its map holds it. A ReferenceSet outside a map is read as
// its float32 descriptors (bitwise what a float32 map gives).
// Throws std::invalid_argument if the dimensions differ or a query holds NaN/infinity.
RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const StoredReferenceSet& set);
RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const ReferenceSet& set);

// The same for every set of `map`: element u is Q x N_u for set u.
std::vector<RowMatrixXf> ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                                          const ReferenceSets& map);

// Throws std::invalid_argument naming the first query row that DescriptorProblem refuses
// (NaN, infinity, or values whose squared norm overflows): every distance function's check.
void CheckQueryDescriptors(const RowMatrixXf& queries);

// Views on row `query` of each per-set matrix, with each set's place ids and group (`groups`
// empty: every set in group 0).
std::vector<SetDistances> QueryRowViews(const std::vector<RowMatrixXf>& per_set, int query,
                                        const std::vector<const std::vector<int>*>& place_ids,
                                        const std::vector<int>& groups = {});

// Turns a Q x N similarity matrix (higher is more similar) into non-negative distances
// c - s with c = max(1, largest similarity): for cosine similarities this is exactly the
// cosine distance. Pass the same `offset` to all sources of one evaluation so that they
// stay comparable; SimilarityOffset() computes it over several matrices.
float SimilarityOffset(const std::vector<const RowMatrixXf*>& similarities);
void SimilaritiesToDistances(float offset, RowMatrixXf* matrix);

}  // namespace bsf_vpr
