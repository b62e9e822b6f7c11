// The scalar parts every distance kernel shares (distance_kernels.cpp and the tiles of
// distance_tiles-inl.h, compiled once per target): the eight lanes and their fixed reduction
// tree, the tile's arguments, the int8 rules. Included by the kernels' translation units
// alone, which are compiled with -ffp-contract=off.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "src/core/internal/distance_kernels.h"

namespace bsf_vpr {
namespace kernels {
namespace {

constexpr int kLanes = 8;
// Queries from which a tile gains by passes over L1-sized pieces of the rows (and by an
// aligned copy of the queries), from which pairs of queries pay, and from which lane-major
// panels do (the rows' packing is paid back by the panels of queries that pass over them).
constexpr int kBatchQueries = 8;
constexpr int kPackQueries = 32;
// The lane-major tiles: panels of 12 queries x 32 rows (distance_lanes-inl.h; on targets
// narrower than 16 floats, tiles of half of each).
constexpr int kLaneQueries = 12;
constexpr int kLaneRows = 32;

// `buffer` sized for `count` floats starting on a 64-byte boundary; returns that start.
inline float* On64Bytes(size_t count, std::vector<float>* buffer) {
  buffer->resize(count + 16);
  float* p = buffer->data();
  return p + (16 - (reinterpret_cast<uintptr_t>(p) / sizeof(float)) % 16) % 16;
}

// The fixed reduction tree of the eight lanes.
inline float ReduceLanes(const float* l) {
  return ((l[0] + l[4]) + (l[1] + l[5])) + ((l[2] + l[6]) + (l[3] + l[7]));
}

inline float Decode(float v) { return v; }
inline float Decode(uint16_t v) { return HalfToFloat(v); }

// The last, partial block of a row, zero-padded to eight lanes.
template <class T>
inline void PadTail(const T* row, int from, int n, float* lanes) {
  for (int k = 0; k < kLanes; ++k) lanes[k] = from + k < n ? Decode(row[from + k]) : 0.0f;
}

// A tile: NQ queries x NR rows over the elements [i0, i1) of a row. `first`: the lanes start
// at zero, else they continue from `lanes` (pair (j, k) at lanes + j * lanes_stride + k * 8).
// At the row's end (i1 == d) the lanes are reduced into out[j * out_stride + k]; before it
// they are stored back to `lanes`. Splitting a row into such passes keeps every lane's
// additions in the same order, so chunked and whole-row tiles give the same bits.
struct TileArgs {
  const float* q = nullptr;
  int q_stride = 0;
  int i0 = 0, i1 = 0, d = 0;
  bool first = true;
  float* lanes = nullptr;
  int lanes_stride = 0;
  float* out = nullptr;
  int out_stride = 0;
  // int8 rows only: the queries rounded to int16 (query j at q16 + j * q_stride), the scale
  // of each (q_scales[j]) and the rows' scale.
  float scale = 1.0f;
  const int16_t* q16 = nullptr;
  const float* q_scales = nullptr;
  // Pair tiles only: queries 2p and 2p + 1 interleaved in blocks of eight elements
  // (pair p at pairs + p * pairs_stride; see Queries::pairs).
  const float* pairs = nullptr;
  int pairs_stride = 0;
};

// ---- int8 rows: integer inner products -----------------------------------------------
// The query is rounded to int16 with its own scale and each pair's products are summed
// exactly in integers (int32 lanes that cannot overflow, see QueryLevels), so the value
// does not depend on any order: every kernel and every tile give the same bits.

inline float Int8Result(int64_t sum, float row_scale, float query_scale) {
  return static_cast<float>(static_cast<double>(sum) *
                            (static_cast<double>(row_scale) * static_cast<double>(query_scale)));
}

// One pair's inner product from its `count` int32 lanes and the elements [from, d) that no
// whole vector step covered, summed exactly; then scaled.
inline float Int8Finish(const int32_t* lanes, int count, const int16_t* q, const int8_t* row,
                        int from, int d, float row_scale, float query_scale) {
  int64_t sum = 0;
  for (int l = 0; l < count; ++l) sum += lanes[l];
  for (int t = from; t < d; ++t) sum += static_cast<int32_t>(q[t]) * row[t];
  return Int8Result(sum, row_scale, query_scale);
}

// Largest |int16 level| of a query such that an int32 lane (d / 8 products of at most
// 127 x level) cannot overflow.
inline int QueryLevels(int d) {
  const int64_t bound = (int64_t{2147483647} * 8) / (int64_t{127} * std::max(d, 8));
  return static_cast<int>(std::min<int64_t>(32767, bound));
}

}  // namespace
}  // namespace kernels
}  // namespace bsf_vpr
