// The distance kernels' driver, compiled once per Highway target (foreach_target.h includes
// this file again for each, with distance_tiles-inl.h and distance_lanes-inl.h), and the
// dispatch to the chosen target (simd_targets.h), once per call of Dots or SelfDot. Compiled
// with -ffp-contract=off, so that the portable target multiplies then adds as written.
#include "src/core/internal/simd_targets.h"  // first: the targets, before any Highway header
//
#include <algorithm>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "src/core/internal/distance_kernels.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "src/core/internal/distance_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
//
#include <hwy/highway.h>

#include "src/core/internal/distance_formula.h"
#include "src/core/internal/distance_lanes-inl.h"
#include "src/core/internal/distance_tiles-inl.h"
#include "src/core/internal/kernel_common.h"

HWY_BEFORE_NAMESPACE();
namespace bsf_vpr {
namespace kernels {
namespace HWY_NAMESPACE {

// ---- driver: tiles over a block of rows that stays in cache ---------------------------

template <class T, int NQ, int NR>
HWY_INLINE void Tile(const TileArgs& a, const T* r, int r_stride) {
  if constexpr (std::is_same_v<T, int8_t>) {
    TileInt8<NQ, NR>(a, r, r_stride);
  } else {
    TileRows<T, NQ, NR>(a, r, r_stride);
  }
}

// One pass of NQ queries (a.q, a.out and a.lanes at their first) over the rows [b0, b1),
// NR rows a tile and the remainder one by one.
template <class T, int NQ, int NR>
void Sweep(TileArgs a, const T* rows, int b0, int b1) {
  float* const out = a.out;
  float* const lanes = a.lanes;
  int r = b0;
  const auto at = [&](int row) {
    a.out = out + (row - b0);
    a.lanes = lanes ? lanes + (row - b0) * kLanes : nullptr;
    return rows + static_cast<size_t>(row) * a.d;
  };
  for (; r + NR <= b1; r += NR) Tile<T, NQ, NR>(a, at(r), a.d);
  for (; r < b1; ++r) Tile<T, NQ, 1>(a, at(r), a.d);
}

// The same over pairs of queries (a.pairs, a.out and a.lanes at the pair's first query).
template <int NP, int NR>
void SweepPairs(TileArgs a, const float* rows, int b0, int b1) {
  float* const out = a.out;
  float* const lanes = a.lanes;
  const auto at = [&](int row) {
    a.out = out + (row - b0);
    a.lanes = lanes ? lanes + (row - b0) * 2 * kLanes : nullptr;
    return rows + static_cast<size_t>(row) * a.d;
  };
  int r = b0;
  for (; r + NR <= b1; r += NR) TilePairs<NP, NR>(a, at(r), a.d);
  for (; r < b1; ++r) TilePairs<NP, 1>(a, at(r), a.d);
}

// A batch by lane: the rows kPackRows at a time packed by lane (PackRowLanes, in L2 while
// every panel of 12 queries passes over them), then made distances while in cache.
template <class T>
void DotsLanes(const T* rows, int r0, int r1, const Queries& queries, float* out, int out_stride,
               const ToDistancesArgs* finish) {
  const int d = queries.cols, steps = queries.lane_steps, num_queries = queries.rows;
  std::vector<float> packing;
  float* const packed = On64Bytes(static_cast<size_t>(kLanes) * steps * kPackRows, &packing);
  const size_t panel = static_cast<size_t>(kLanes) * steps * kLaneQueries;
  for (int b0 = r0; b0 < r1; b0 += kPackRows) {
    const int count = std::min(kPackRows, r1 - b0);
    PackRowLanes(rows, d, b0, count, packed);
    for (int q0 = 0; q0 < num_queries; q0 += kLaneQueries) {
      TileLanes(queries.lanes.data() + (q0 / kLaneQueries) * panel, packed, steps,
                out + static_cast<size_t>(q0) * out_stride + (b0 - r0), out_stride,
                std::min(kLaneQueries, num_queries - q0), count);
    }
    if (finish != nullptr) {
      for (int q = 0; q < num_queries; ++q) {
        formula::ToDistances(finish->metric, finish->query_squared_norms[q],
                             finish->row_squared_norms + b0, 0, count,
                             out + static_cast<size_t>(q) * out_stride + (b0 - r0));
      }
    }
  }
}

// The queries q0 <= q < q1 of a block over the rows [b0, b1), in pairs where prepared so.
template <class T>
void SweepQueries(const TileArgs& a, const Queries& queries, int q0, int q1, const T* rows, int b0,
                  int b1, bool pairs, float* out, int out_stride, int r0, float* lanes) {
  const bool int8_rows = std::is_same_v<T, int8_t>;
  const int d = queries.cols;
  const auto for_query = [&](int q) {
    TileArgs b = a;
    b.q = queries.data + static_cast<size_t>(q) * queries.stride;
    if (int8_rows) {
      b.q16 = queries.levels.data() + static_cast<size_t>(q) * d;
      b.q_scales = queries.scales.data() + q;
    }
    b.out = out + static_cast<size_t>(q) * out_stride + (b0 - r0);
    if (lanes != nullptr) b.lanes = lanes + static_cast<size_t>(q - q0) * a.lanes_stride;
    return b;
  };
  int q = q0;
  if constexpr (std::is_same_v<T, float>) {
    if (pairs) {  // pair p = q / 2 (a block starts on an even query)
      const auto for_pair = [&](int first) {
        TileArgs b = for_query(first);
        b.pairs = queries.pairs.data() + static_cast<size_t>(first / 2) * queries.pairs_stride;
        b.pairs_stride = queries.pairs_stride;
        b.lanes_stride = 2 * a.lanes_stride;
        return b;
      };
      for (; q + 8 <= q1; q += 8) SweepPairs<4, 6>(for_pair(q), rows, b0, b1);
      for (; q + 2 <= q1; q += 2) SweepPairs<1, 6>(for_pair(q), rows, b0, b1);
    }
  }
  for (; q + 4 <= q1; q += 4) Sweep<T, 4, 3>(for_query(q), rows, b0, b1);
  for (; q < q1; ++q) Sweep<T, 1, 6>(for_query(q), rows, b0, b1);
}

template <class T>
void DotsTyped(const T* rows, float scale, int r0, int r1, const Queries& queries, float* out,
               int out_stride, const ToDistancesArgs* finish) {
  if constexpr (!std::is_same_v<T, int8_t>) {
    if (!queries.lanes.empty()) return DotsLanes(rows, r0, r1, queries, out, out_stride, finish);
  }
  const int d = queries.cols, num_queries = queries.rows;
  // Like a matrix product's blocking: rows in blocks of 96 (in L2 while a block of 32
  // queries passes over them), and rows cut into passes of 1024 elements, so that a tile's
  // pieces (4 queries and 3 rows, at most 28 KiB) stay in L1 while it works on them. A few
  // queries get no reuse from it, so they take whole rows (sequential reads, for memory).
  // (Measured on the project's machine: passes of 512-1024 reach about 1.5x the speed of
  // whole rows for 256 queries x 3000 rows x 4096. The AVX-512 pair tiles were measured with
  // passes of 256 to 4096 on a 2-core AMD EPYC (Zen 4): 1024 and longer equally fast.)
  constexpr int kRowBlock = 96, kQueryBlock = 32;
  const bool int8_rows = std::is_same_v<T, int8_t>;
  if (int8_rows && queries.levels.empty()) {
    throw std::logic_error("int8 rows need queries prepared with int16 levels");
  }
  const bool pairs = std::is_same_v<T, float> && !queries.pairs.empty();
  const int chunk = num_queries >= kBatchQueries && !int8_rows ? 1024 : d;
  std::vector<float> lanes(chunk < d ? static_cast<size_t>(kQueryBlock) * kRowBlock * kLanes : 0);
  TileArgs a;
  a.q_stride = int8_rows ? d : queries.stride;  // int16 levels are packed
  a.d = d;
  a.lanes_stride = kRowBlock * kLanes;
  a.scale = scale;
  a.out_stride = out_stride;
  for (int b0 = r0; b0 < r1; b0 += kRowBlock) {
    const int b1 = std::min(r1, b0 + kRowBlock);
    for (int qb0 = 0; qb0 < num_queries; qb0 += kQueryBlock) {
      const int qb1 = std::min(num_queries, qb0 + kQueryBlock);
      for (int i0 = 0; i0 < d; i0 += chunk) {
        a.i0 = i0;
        a.i1 = std::min(d, i0 + chunk);
        a.first = i0 == 0;
        SweepQueries(a, queries, qb0, qb1, rows, b0, b1, pairs, out, out_stride, r0,
                     lanes.empty() ? nullptr : lanes.data());
      }
      if (finish != nullptr) {
        for (int q = qb0; q < qb1; ++q) {
          formula::ToDistances(finish->metric, finish->query_squared_norms[q],
                               finish->row_squared_norms + b0, 0, b1 - b0,
                               out + static_cast<size_t>(q) * out_stride + (b0 - r0));
        }
      }
    }
  }
}

void DotsTarget(const RefRows& refs, int r0, int r1, const Queries& queries, float* out,
                int out_stride, const ToDistancesArgs* finish) {
  switch (refs.precision) {
    case StoragePrecision::kFloat32:
      return DotsTyped(static_cast<const float*>(refs.data), 1.0f, r0, r1, queries, out, out_stride,
                       finish);
    case StoragePrecision::kFloat16:
      return DotsTyped(static_cast<const uint16_t*>(refs.data), 1.0f, r0, r1, queries, out,
                       out_stride, finish);
    case StoragePrecision::kInt8:
      return DotsTyped(static_cast<const int8_t*>(refs.data), refs.scale, r0, r1, queries, out,
                       out_stride, finish);
  }
}

float SelfDotTarget(const float* x, int n) {
  float out = 0;
  TileArgs a;
  a.q = x;
  a.q_stride = n;
  a.i1 = a.d = n;
  a.out = &out;
  a.out_stride = 1;
  TileRows<float, 1, 1>(a, x, n);
  return out;
}

// Floats to a full register: where pairs pay (16) and lanes (8 and 16).
int FloatLanesTarget() { return static_cast<int>(hn::Lanes(hn::ScalableTag<float>())); }

}  // namespace HWY_NAMESPACE
}  // namespace kernels
}  // namespace bsf_vpr
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace bsf_vpr {
namespace kernels {

HWY_EXPORT(DotsTarget);
HWY_EXPORT(SelfDotTarget);
HWY_EXPORT(FloatLanesTarget);

namespace {

// Pairs of queries interleaved in blocks of eight, zero-padded to a whole block (an odd last
// query is read where it is).
void PreparePairs(const float* data, int rows, int stride, int cols, Queries* out) {
  const int blocks = (cols + kLanes - 1) / kLanes;
  out->pairs_stride = 2 * kLanes * blocks;
  out->pairs.assign(static_cast<size_t>(rows / 2) * out->pairs_stride + 16, 0.0f);
  for (int q = 0; q < rows / 2 * 2; ++q) {
    const float* from = data + static_cast<size_t>(q) * stride;
    float* to =
        out->pairs.data() + static_cast<size_t>(q / 2) * out->pairs_stride + (q % 2) * kLanes;
    for (int i = 0; i < cols; ++i) to[(i / kLanes) * 2 * kLanes + i % kLanes] = from[i];
  }
}

// Panels of 12 queries, each lane's elements in order (TileLanes).
void PrepareLanes(const float* data, int rows, int stride, int cols, Queries* out) {
  const int steps = (cols + kLanes - 1) / kLanes;
  const int panels = (rows + kLaneQueries - 1) / kLaneQueries;
  out->lane_steps = steps;
  out->lanes.assign(static_cast<size_t>(panels) * kLanes * steps * kLaneQueries, 0.0f);
  for (int q = 0; q < rows; ++q) {
    const float* from = data + static_cast<size_t>(q) * stride;
    float* to = out->lanes.data() +
                static_cast<size_t>(q / kLaneQueries) * kLanes * steps * kLaneQueries +
                q % kLaneQueries;
    for (int i = 0; i < cols; ++i) {
      to[(static_cast<size_t>(i % kLanes) * steps + i / kLanes) * kLaneQueries] = from[i];
    }
  }
}

// Each query rounded to int16 levels with its own scale (int8 rows).
void PrepareLevels(const float* data, int rows, int stride, int cols, Queries* out) {
  const int levels = QueryLevels(cols);
  out->levels.resize(static_cast<size_t>(rows) * cols);
  out->scales.resize(static_cast<size_t>(rows));
  for (int q = 0; q < rows; ++q) {
    const float* x = data + static_cast<size_t>(q) * stride;
    float max_abs = 0;
    for (int i = 0; i < cols; ++i) max_abs = std::max(max_abs, std::fabs(x[i]));
    const float s = max_abs > 0 ? max_abs / static_cast<float>(levels) : 1.0f;
    out->scales[static_cast<size_t>(q)] = s;
    for (int i = 0; i < cols; ++i) {
      const float level = std::nearbyint(x[i] / s);
      out->levels[static_cast<size_t>(q) * cols + i] = static_cast<int16_t>(
          std::clamp(level, -static_cast<float>(levels), static_cast<float>(levels)));
    }
  }
}

}  // namespace

Queries PrepareQueries(const float* data, int rows, int stride, int cols, bool int16_levels,
                       QueryLayout layout) {
  Queries out;
  out.data = data;
  out.rows = rows;
  out.cols = cols;
  out.stride = stride;
  if (layout == QueryLayout::kAuto) {
    const int width = BSF_VPR_DISPATCH(FloatLanesTarget)();
    const bool wide = width >= 2 * kLanes;
    layout = width >= kLanes && rows >= kPackQueries ? QueryLayout::kLanes
             : wide && rows >= kBatchQueries         ? QueryLayout::kPairs
                                                     : QueryLayout::kRows;
  }
  if (layout == QueryLayout::kLanes) {
    PrepareLanes(data, rows, stride, cols, &out);
  } else if (layout == QueryLayout::kPairs && rows >= 2) {
    PreparePairs(data, rows, stride, cols, &out);
  } else if (rows >= kBatchQueries) {  // a batch reads every query many times: align its rows
    const int aligned_stride = (cols + 15) / 16 * 16;
    float* const base = On64Bytes(static_cast<size_t>(rows) * aligned_stride, &out.aligned);
    for (int q = 0; q < rows; ++q) {
      const float* from = data + static_cast<size_t>(q) * stride;
      std::copy(from, from + cols, base + static_cast<size_t>(q) * aligned_stride);
    }
    out.data = base;
    out.stride = aligned_stride;
  }
  if (int16_levels) PrepareLevels(data, rows, stride, cols, &out);
  return out;
}

void Dots(const RefRows& refs, int r0, int r1, const Queries& queries, float* out, int out_stride,
          const ToDistancesArgs* finish) {
  BSF_VPR_DISPATCH(DotsTarget)(refs, r0, r1, queries, out, out_stride, finish);
}

float SelfDot(const float* x, int n) { return BSF_VPR_DISPATCH(SelfDotTarget)(x, n); }

}  // namespace kernels
}  // namespace bsf_vpr
#endif  // HWY_ONCE
