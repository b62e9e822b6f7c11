// The lane-major tiles of the distance kernels (QueryLayout::kLanes), written once over
// Google Highway and compiled once per target with distance_tiles-inl.h. Included by
// distance_kernels.cpp alone.
//
// Lane j of a pair (query, row) is the sum, from zero, of one multiply-add per element
// i = j (mod 8) in increasing i: for each lane, a matrix product of the queries' and the rows'
// elements of that lane, each output accumulated in order. So a tile of 12 queries x 32 rows
// runs as a matrix product's micro-kernel does: per element, one query element broadcast
// against the 32 rows' elements in registers. The eight lanes run one after another and are
// added in ReduceLanes's tree: the same bits as the other tiles. With 16 floats a register
// (AVX-512) that is 24 registers of sums and two of rows, about a third of the pair tiles'
// load traffic per FMA (measured on Zen 5 at 93-99% of OpenBLAS sgemm's throughput). With 8
// (AVX2) the 48 sums would not fit in 16 registers: there the rows are packed 16 at a time
// and a panel of 12 queries runs as two tiles of 6 queries x 16 rows (12 registers of sums,
// two of rows, one broadcast: the shape of OpenBLAS's own AVX2 sgemm kernel), and a block of
// packed rows (256 KiB at 4096-d) stays in a 512 KiB L2 (Zen 3) with a panel of queries.
// Narrower targets take the AVX2 shapes too (in the tests; PrepareQueries does not choose
// lanes there).

#if defined(BSF_VPR_DISTANCE_LANES_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef BSF_VPR_DISTANCE_LANES_INL_H_
#undef BSF_VPR_DISTANCE_LANES_INL_H_
#else
#define BSF_VPR_DISTANCE_LANES_INL_H_
#endif

#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include "src/core/internal/distance_tiles-inl.h"

HWY_BEFORE_NAMESPACE();
namespace bsf_vpr {
namespace kernels {
namespace HWY_NAMESPACE {

// The target's widest float vector: 16 floats (AVX-512) take a whole panel of kLaneQueries x
// kLaneRows in one tile, narrower ones tiles of half the queries over half the rows.
constexpr bool kWideLanes = hn::MaxLanes(hn::ScalableTag<float>()) >= 16;
constexpr int kPackRows = kWideLanes ? kLaneRows : kLaneRows / 2;           // rows packed a block
constexpr int kTileQueries = kWideLanes ? kLaneQueries : kLaneQueries / 2;  // queries a tile
using DL = hn::CappedTag<float, kPackRows>;
using VL = hn::Vec<DL>;
constexpr int kWL = static_cast<int>(hn::MaxLanes(DL()));
constexpr int kVecsL = kPackRows / kWL;
using LaneSums = VL[kTileQueries][kVecsL];

#undef BSF_VPR_TRANSPOSE_EIGHT              // this file is included once per target
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2  // 8-float vectors of two 128-bit halves
#define BSF_VPR_TRANSPOSE_EIGHT 1
// Eight rows' blocks of eight elements (row k's at src + k * d) transposed: lane j's eight
// values (one per row) stored at to + j * lane_stride. Unpacks within 128-bit halves, then
// the halves exchanged: 24 shuffles for 64 values where element by element took 128 moves.
template <class T>
HWY_INLINE void TransposeEight(const T* src, size_t d, float* to, size_t lane_stride) {
  const D8 d8;
  const hn::Repartition<double, D8> d64;
  V8 v[kLanes];
  for (int k = 0; k < kLanes; ++k) v[k] = LoadFloats(d8, src + k * d);
  // Rows (a b), (c d), ... interleaved by element: a0 b0 a1 b1 | a4 b4 a5 b5 and the uppers.
  V8 t[kLanes];
  for (int k = 0; k < kLanes; k += 2) {
    t[k] = hn::InterleaveLower(d8, v[k], v[k + 1]);
    t[k + 1] = hn::InterleaveUpper(d8, v[k], v[k + 1]);
  }
  // Then by pairs: u[4 h + e] holds rows 4h..4h+3 of elements e and e + 4.
  V8 u[kLanes];
  for (int h = 0; h < 2; ++h) {
    for (int i = 0; i < 2; ++i) {
      const auto lo = hn::BitCast(d64, t[4 * h + i]), hi = hn::BitCast(d64, t[4 * h + 2 + i]);
      u[4 * h + 2 * i] = hn::BitCast(d8, hn::InterleaveLower(d64, lo, hi));
      u[4 * h + 2 * i + 1] = hn::BitCast(d8, hn::InterleaveUpper(d64, lo, hi));
    }
  }
  // Lane j (j < 4): the lower halves of u[j] (rows 0-3) and u[4 + j] (rows 4-7); lane j + 4
  // the upper halves.
  for (int j = 0; j < 4; ++j) {
    hn::StoreU(hn::ConcatLowerLower(d8, u[4 + j], u[j]), d8, to + j * lane_stride);
    hn::StoreU(hn::ConcatUpperUpper(d8, u[4 + j], u[j]), d8, to + (j + 4) * lane_stride);
  }
}
#else
#define BSF_VPR_TRANSPOSE_EIGHT 0
#endif

// Rows [b0, b0 + count) (count <= kPackRows; d float32 or float16 values each) packed as
// floats: lane j's step t (element 8 t + j of each row; zero past d and past count) at
// packed + (j * steps + t) * kPackRows, steps = ceil(d / 8). `packed` on 64 bytes. Eight
// rows' blocks of eight elements at a time: transposed in registers on x86 where all eight
// are there, else decoded with vectors and written lane by lane.
template <class T>
void PackRowLanes(const T* rows, int d, int b0, int count, float* packed) {
  const D8 d8;
  const int steps = (d + kLanes - 1) / kLanes, full = d / kLanes;
  const size_t lane_stride = static_cast<size_t>(steps) * kPackRows;
  // The rows come from memory (a set is far larger than the caches), in 16 or 32 streams:
  // each row's line 1 KiB ahead is asked for once per line, so that the reads overlap.
  constexpr int kAheadSteps = 1024 / (kLanes * static_cast<int>(sizeof(T)));
  constexpr int kStepsPerLine = 64 / (kLanes * static_cast<int>(sizeof(T)));
  for (int t = 0; t < steps; ++t) {
    if (t % kStepsPerLine == 0 && t + kAheadSteps < full) {
      for (int k = 0; k < count; ++k) {
        hwy::Prefetch(rows + static_cast<size_t>(b0 + k) * d + (t + kAheadSteps) * kLanes);
      }
    }
    for (int g = 0; g < kPackRows; g += kLanes) {
      float* const to = packed + static_cast<size_t>(t) * kPackRows + g;
#if BSF_VPR_TRANSPOSE_EIGHT
      if (t < full && g + kLanes <= count) {
        TransposeEight(rows + static_cast<size_t>(b0 + g) * d + t * kLanes, static_cast<size_t>(d),
                       to, lane_stride);
        continue;
      }
#endif
      HWY_ALIGN float block[kLanes][kLanes];
      for (int k = 0; k < kLanes; ++k) {
        const T* row = g + k < count ? rows + static_cast<size_t>(b0 + g + k) * d : nullptr;
        if (row == nullptr) {
          std::fill(block[k], block[k] + kLanes, 0.0f);
        } else if (t < full) {
          for (int v = 0; v < kVecs8; ++v) {
            hn::Store(LoadFloats(d8, row + t * kLanes + v * kW8), d8, block[k] + v * kW8);
          }
        } else {
          PadTail(row, t * kLanes, d, block[k]);
        }
      }
      for (int j = 0; j < kLanes; ++j) {
        for (int k = 0; k < kLanes; ++k) to[j * lane_stride + k] = block[k][j];
      }
    }
  }
}

// One lane of a tile: acc[q][h] = sum over the steps, from zero, of a[q] * b[h * kWL ..],
// a stepping by kLaneQueries (a panel's width) and b by kPackRows.
HWY_INLINE void LanePass(const float* a, const float* b, int steps, LaneSums& acc) {
  const DL dl;
  for (int q = 0; q < kTileQueries; ++q) {
    for (int h = 0; h < kVecsL; ++h) acc[q][h] = hn::Zero(dl);
  }
  for (int t = 0; t < steps; ++t, a += kLaneQueries, b += kPackRows) {
    VL rv[kVecsL];
    for (int h = 0; h < kVecsL; ++h) rv[h] = hn::Load(dl, b + h * kWL);
    for (int q = 0; q < kTileQueries; ++q) {
      const VL x = hn::Set(dl, a[q]);
      for (int h = 0; h < kVecsL; ++h) acc[q][h] = LaneMulAdd(x, rv[h], acc[q][h]);
    }
  }
}
HWY_INLINE void KeepLanes(const LaneSums& acc, float* keep) {
  for (int q = 0; q < kTileQueries; ++q) {
    for (int h = 0; h < kVecsL; ++h) hn::Store(acc[q][h], DL(), keep + q * kPackRows + h * kWL);
  }
}
// acc = keep + acc (a float sum's operands commute: the bits of acc + keep).
HWY_INLINE void AddKeptLanes(const float* keep, LaneSums& acc) {
  for (int q = 0; q < kTileQueries; ++q) {
    for (int h = 0; h < kVecsL; ++h) {
      acc[q][h] = hn::Add(hn::Load(DL(), keep + q * kPackRows + h * kWL), acc[q][h]);
    }
  }
}

// Lanes j and j + 4 of a tile (lane j's step t at a + (j * steps + t) * kLaneQueries, and at
// b + (j * steps + t) * 32): acc = l_j + l_{j+4}, lane j kept in `scratch` meanwhile.
HWY_INLINE void LanePair(const float* a, const float* b, int steps, int j, float* scratch,
                         LaneSums& acc) {
  const auto lane_a = [a, steps](int k) {
    return a + static_cast<size_t>(k) * steps * kLaneQueries;
  };
  const auto lane_b = [b, steps](int k) { return b + static_cast<size_t>(k) * steps * kPackRows; };
  LanePass(lane_a(j), lane_b(j), steps, acc);
  KeepLanes(acc, scratch);
  LanePass(lane_a(j + 4), lane_b(j + 4), steps, acc);
  AddKeptLanes(scratch, acc);
}

// The inner products of kTileQueries queries of a panel (packed: lane j's step t at
// a + (j * steps + t) * kLaneQueries) with a block of rows (PackRowLanes) into
// out[q * out_stride + r] for q < queries, r < rows: lanes in pairs (0 4, 1 5, 2 6, 3 7),
// added as ((l0 + l4) + (l1 + l5)) + ((l2 + l6) + (l3 + l7)).
void TileLanesPart(const float* a, const float* b, int steps, float* out, int out_stride,
                   int queries, int rows) {
  LaneSums acc;
  HWY_ALIGN float keep[3][kTileQueries * kPackRows];  // two partial sums and a scratch
  LanePair(a, b, steps, 0, keep[2], acc);             // l0 + l4
  KeepLanes(acc, keep[0]);
  LanePair(a, b, steps, 1, keep[2], acc);  // l1 + l5
  AddKeptLanes(keep[0], acc);              // (l0 + l4) + (l1 + l5)
  KeepLanes(acc, keep[0]);
  LanePair(a, b, steps, 2, keep[2], acc);  // l2 + l6
  KeepLanes(acc, keep[1]);
  LanePair(a, b, steps, 3, keep[2], acc);  // l3 + l7
  AddKeptLanes(keep[1], acc);              // (l2 + l6) + (l3 + l7)
  AddKeptLanes(keep[0], acc);              // the whole tree
  if (rows == kPackRows) {
    for (int q = 0; q < queries; ++q) {
      for (int h = 0; h < kVecsL; ++h) {
        hn::StoreU(acc[q][h], DL(), out + static_cast<size_t>(q) * out_stride + h * kWL);
      }
    }
    return;
  }
  KeepLanes(acc, keep[0]);  // a partial panel: its rows alone
  for (int q = 0; q < queries; ++q) {
    std::copy(keep[0] + q * kPackRows, keep[0] + q * kPackRows + rows,
              out + static_cast<size_t>(q) * out_stride);
  }
}

// A panel of queries (up to kLaneQueries) over a block of rows, kTileQueries at a time.
void TileLanes(const float* a, const float* b, int steps, float* out, int out_stride, int queries,
               int rows) {
  for (int q0 = 0; q0 < queries; q0 += kTileQueries) {
    TileLanesPart(a + q0, b, steps, out + static_cast<size_t>(q0) * out_stride, out_stride,
                  std::min(kTileQueries, queries - q0), rows);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace kernels
}  // namespace bsf_vpr
HWY_AFTER_NAMESPACE();

#endif  // BSF_VPR_DISTANCE_LANES_INL_H_
