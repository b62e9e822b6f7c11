// Inner products of queries with stored reference rows: the kernels behind ComputeDistances.
//
// Every pair (query, reference row) is summed in one fixed order whatever the kernel, the
// tile it falls in, the thread or the batch: eight lanes, lane k accumulating the elements
// i = k (mod 8) in increasing i (the last block zero-padded), then the lanes added in the
// tree ((l0 + l4) + (l1 + l5)) + ((l2 + l6) + (l3 + l7)). One query's distances are thus
// bitwise the same online and in an offline batch. The kernels are written once over Google
// Highway and compiled for each instruction set (simd_targets.h): every SIMD target (AVX2,
// AVX-512, NEON) multiply-adds with FMA (one rounding) and gives the same bits as every
// other; the portable one multiplies then adds; a process uses one of them.
// int8 rows are the exception that needs no order: the query is rounded to int16 levels
// (its own scale) and the products are summed exactly in integers, the same on every kernel.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bsf_vpr/core/descriptor_store.h"
#include "bsf_vpr/core/distances.h"

namespace bsf_vpr {
namespace kernels {

// Reference rows as the kernel reads them.
struct RefRows {
  StoragePrecision precision = StoragePrecision::kFloat32;
  const void* data = nullptr;  // rows of `cols` elements (float, uint16_t half or int8_t)
  int cols = 0;
  float scale = 1.0f;  // int8: each inner product is multiplied by it
};

// Queries as the kernels read them, made once per distance computation and shared by every
// set and thread: the float32 rows (for a batch, a copy whose rows start on 64-byte
// boundaries, so that no 32-byte load straddles a cache line) and, for int8 rows, each
// query rounded to int16 levels with its own scale.
// `data` may point into `aligned`: a copy would point into the original, so there is none.
// A move keeps the pointer valid (a moved std::vector hands over its buffer).
struct Queries {
  Queries() = default;
  Queries(const Queries&) = delete;
  Queries& operator=(const Queries&) = delete;
  Queries(Queries&&) = default;
  Queries& operator=(Queries&&) = default;

  const float* data = nullptr;  // query q at data + q * stride
  int rows = 0, cols = 0, stride = 0;
  std::vector<float> aligned;   // holds `data` when copied
  std::vector<int16_t> levels;  // rows x cols, for int8 rows
  std::vector<float> scales;    // rows, for int8 rows
  // Batches of 8 to 31 queries in pairs (QueryLayout::kPairs): queries 2p and 2p + 1 interleaved in
  // blocks of eight elements (block b of query 2p at p * pairs_stride + 16 b, of 2p + 1 eight
  // further), zero-padded to a whole block; an odd last query is not in it.
  std::vector<float> pairs;
  int pairs_stride = 0;
  // Batches of 32 queries or more by lane (QueryLayout::kLanes): the queries in panels of 12
  // (zero-padded), each lane's elements in order: query 12 P + k's element 8 t + j at
  // lanes[((P * 8 + j) * lane_steps + t) * 12 + k], lane_steps = ceil(cols / 8), zero past cols.
  std::vector<float> lanes;
  int lane_steps = 0;
};
// How a batch runs: by rows (every kernel's tiles of 4 queries x 3 rows), by pairs of queries
// (tiles of 4 pairs x 6 rows, two queries' eight lanes in one 16-float register: float32 rows
// only) or by lane (for float32 and float16 rows from 32 queries: each lane a matrix product
// over panels of 12 queries x 32 rows, or on kernels of 8 floats to a register tiles of
// 6 queries x 16 rows). The three give the same bits on every kernel; kAuto takes pairs where
// they pay, on kernels with 16 floats to a register (AVX-512: enough registers for their
// sums), lanes on those and on 8-float ones (AVX2), rows elsewhere. The tests ask for each on
// every kernel.
enum class QueryLayout { kAuto, kRows, kPairs, kLanes };

// `data`: `rows` queries of `cols` floats, query q at data + q * stride (not copied unless
// the batch is large enough to gain from it: keep it alive while the result is in use).
// kPairs needs 2 queries or more, kLanes any number (fewer than 8 and 32 only in tests).
Queries PrepareQueries(const float* data, int rows, int stride, int cols, bool int16_levels,
                       QueryLayout layout = QueryLayout::kAuto);

// out[q * out_stride + (r - r0)] = <query q, reference row r> for every query and
// r0 <= r < r1. int8 rows need `queries` prepared with int16 levels.
// With `finish`, each query's inner products are made distances (formula::ToDistances) as
// soon as a block of rows is done, while they are in cache: the same bits as converting them
// afterwards.
struct ToDistancesArgs {
  DistanceMetric metric = DistanceMetric::kEuclidean;
  const float* query_squared_norms = nullptr;  // query q's at [q]
  const float* row_squared_norms = nullptr;    // row r's at [r]
};
void Dots(const RefRows& refs, int r0, int r1, const Queries& queries, float* out, int out_stride,
          const ToDistancesArgs* finish = nullptr);

// <x, x> in the same order (squared norm of a float32 row).
float SelfDot(const float* x, int n);

// "avx512_vnni", "avx512", "avx2", "neon" or "portable" (simd_targets.h): the kernel this
// process uses, by default the best the CPU runs of those compiled for its architecture.
// Force() picks one ("auto" restores the choice by CPU); throws std::invalid_argument for an
// unknown name or for a kernel the CPU cannot run (or that is not compiled for it).
// Available(): the kernels this CPU runs, best first ("portable" last, always there).
std::string Active();
void Force(const std::string& name);
std::vector<std::string> Available();

}  // namespace kernels
}  // namespace bsf_vpr
