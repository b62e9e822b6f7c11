// The distance kernels' tiles, written once over Google Highway's vector types and compiled
// once per target (foreach_target.h re-includes this file, see distance_kernels.cpp). The
// eight lanes of distance_kernels.h are eight logical lanes, 8 / Lanes(d) vectors of a
// CappedTag<float, 8>: one AVX2 register, the lower half of an AVX-512 one, two NEON ones, eight
// scalars on the portable target; each lane's sum runs in the same order on all of them.
// The wider tiles (pairs of queries, lane-major panels) are written the same way over 16 and
// 32 logical lanes; they are chosen where they pay (PrepareQueries) but run and are tested on
// every target. Included by distance_kernels.cpp alone.

// Per-target include guard (Highway's convention): toggled for each target's pass.
#if defined(BSF_VPR_DISTANCE_TILES_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef BSF_VPR_DISTANCE_TILES_INL_H_
#undef BSF_VPR_DISTANCE_TILES_INL_H_
#else
#define BSF_VPR_DISTANCE_TILES_INL_H_
#endif

#include <hwy/highway.h>

#include <algorithm>
#include <cstring>

#include "bsf_vpr/core/descriptor_store.h"
#include "src/core/internal/kernel_common.h"

HWY_BEFORE_NAMESPACE();
namespace bsf_vpr {
namespace kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// a * b + c, fused on the SIMD targets (one rounding, as the contract says) and multiplied then
// added on the portable one (two roundings, as the portable kernel always did).
template <class V>
HWY_INLINE V LaneMulAdd(V a, V b, V c) {
#if HWY_TARGET == HWY_SCALAR || HWY_TARGET == HWY_EMU128
  return hn::Add(hn::Mul(a, b), c);
#else
  return hn::MulAdd(a, b, c);
#endif
}

// Lanes(d) float32 or float16 elements at p as floats.
template <class D>
HWY_INLINE hn::Vec<D> LoadFloats(D d, const float* p) {
  return hn::LoadU(d, p);
}
template <class D>
HWY_INLINE hn::Vec<D> LoadFloats(D d, const uint16_t* p) {
#if HWY_TARGET == HWY_SCALAR
  // Highway's scalar conversion maps the half infinities to finite numbers; HalfToFloat is exact.
  return hn::Set(d, HalfToFloat(*p));
#else
  const hn::Rebind<hwy::float16_t, D> dh;
  return hn::PromoteTo(d, hn::LoadU(dh, reinterpret_cast<const hwy::float16_t*>(p)));
#endif
}

// ---- rows: NQ queries x NR rows, eight lanes each ---------------------------------------
using D8 = hn::CappedTag<float, kLanes>;
using V8 = hn::Vec<D8>;
constexpr int kW8 = static_cast<int>(hn::MaxLanes(D8()));
constexpr int kVecs8 = kLanes / kW8;

// One block of eight lanes: the rows' elements at rp[k], the queries' at qp[j]. Inlined into
// its tile, so that the sums stay in registers.
template <class T, int NQ, int NR>
HWY_INLINE void RowsBlock(const T* const* rp, const float* const* qp, V8 (&acc)[NQ][NR][kVecs8]) {
  const D8 d;
  for (int v = 0; v < kVecs8; ++v) {
    V8 rv[NR];
    for (int k = 0; k < NR; ++k) rv[k] = LoadFloats(d, rp[k] + v * kW8);
    for (int j = 0; j < NQ; ++j) {
      const V8 qv = hn::LoadU(d, qp[j] + v * kW8);
      for (int k = 0; k < NR; ++k) acc[j][k][v] = LaneMulAdd(qv, rv[k], acc[j][k][v]);
    }
  }
}

// A tile is a function of its own (as each was when written per instruction set): inlined into
// the driver, GCC kept its sums in memory, half the speed.
template <class T, int NQ, int NR>
HWY_NOINLINE void TileRows(const TileArgs& a, const T* r, int r_stride) {
  const D8 d;
  V8 acc[NQ][NR][kVecs8];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      for (int v = 0; v < kVecs8; ++v) {
        acc[j][k][v] = a.first ? hn::Zero(d)
                               : hn::LoadU(d, a.lanes + j * a.lanes_stride + k * kLanes + v * kW8);
      }
    }
  }
  const T* rp[NR];
  const float* qp[NQ];
  int i = a.i0;
  for (; i + kLanes <= a.i1; i += kLanes) {
    for (int k = 0; k < NR; ++k) rp[k] = r + k * r_stride + i;
    for (int j = 0; j < NQ; ++j) qp[j] = a.q + j * a.q_stride + i;
    RowsBlock<T, NQ, NR>(rp, qp, acc);
  }
  if (a.i1 < a.d) {
    for (int j = 0; j < NQ; ++j) {
      for (int k = 0; k < NR; ++k) {
        for (int v = 0; v < kVecs8; ++v) {
          hn::StoreU(acc[j][k][v], d, a.lanes + j * a.lanes_stride + k * kLanes + v * kW8);
        }
      }
    }
    return;
  }
  if (i < a.d) {  // the last block, zero-padded
    HWY_ALIGN float rpad[NR][kLanes], qpad[NQ][kLanes];
    const float* rpf[NR];
    for (int k = 0; k < NR; ++k) {
      PadTail(r + k * r_stride, i, a.d, rpad[k]);
      rpf[k] = rpad[k];
    }
    for (int j = 0; j < NQ; ++j) {
      PadTail(a.q + j * a.q_stride, i, a.d, qpad[j]);
      qp[j] = qpad[j];
    }
    RowsBlock<float, NQ, NR>(rpf, qp, acc);
  }
  HWY_ALIGN float lanes[kLanes];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      for (int v = 0; v < kVecs8; ++v) hn::Store(acc[j][k][v], d, lanes + v * kW8);
      a.out[j * a.out_stride + k] = ReduceLanes(lanes);
    }
  }
}

// ---- int8 rows: exact integer sums ---------------------------------------------------
// The row's int8 values widened to int16 and multiplied with the query's int16 levels, each
// pair of neighbouring products added into an int32 lane (madd on x86, VNNI's VPDPWSSD on
// AVX3_DL: one instruction for both; NEON splits them over two sums). A step takes at least 16
// elements, so that no lane takes more than d / 8 products (QueryLevels' bound): 16 on AVX2,
// 32 on AVX-512 (d / 16 a lane), two vectors of 8 on NEON, 16 scalars on the portable target.
using D32 = hn::ScalableTag<int32_t>;
using V32 = hn::Vec<D32>;
#if HWY_TARGET == HWY_SCALAR
using D16 = hn::Rebind<int16_t, D32>;  // one lane of each
#else
using D16 = hn::Repartition<int16_t, D32>;
#endif
using V16 = hn::Vec<D16>;
constexpr int kW16 = static_cast<int>(hn::MaxLanes(D16()));
constexpr int kVecs16 = kW16 >= 16 ? 1 : 16 / kW16;
constexpr int kStep16 = kVecs16 * kW16;
constexpr int kW32 = static_cast<int>(hn::MaxLanes(D32()));

// Highway 1.0.3 names AVX-VNNI ("avxvnni") in AVX3_DL's target string where its run-time
// check requires AVX-512 VNNI: the int8 tile adds the latter for its VPDPWSSD.
#if HWY_TARGET == HWY_AVX3_DL
#define BSF_VPR_VNNI __attribute__((target(HWY_TARGET_STR ",avx512vnni")))
#else
#define BSF_VPR_VNNI
#endif

// sum0 (and sum1) + the products of a and b, exactly.
BSF_VPR_VNNI HWY_INLINE V32 MulAccumulatePairs(V16 a, V16 b, V32 sum0, V32& sum1) {
#if HWY_TARGET == HWY_AVX3_DL
  (void)sum1;
  return V32{_mm512_dpwssd_epi32(sum0.raw, a.raw, b.raw)};
#elif HWY_TARGET == HWY_SCALAR
  (void)sum1;
  const D32 d32;
  return hn::Add(sum0, hn::Mul(hn::PromoteTo(d32, a), hn::PromoteTo(d32, b)));
#else
  return hn::ReorderWidenMulAccumulate(D32(), a, b, sum0, sum1);
#endif
}

template <int NQ, int NR>
BSF_VPR_VNNI HWY_NOINLINE void TileInt8(const TileArgs& a, const int8_t* r, int r_stride) {
  const D32 d32;
  const D16 d16;
  const hn::Rebind<int8_t, D16> d8;
  V32 acc[NQ][NR][kVecs16], acc1[NQ][NR][kVecs16];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      for (int v = 0; v < kVecs16; ++v) acc[j][k][v] = acc1[j][k][v] = hn::Zero(d32);
    }
  }
  int i = 0;
  for (; i + kStep16 <= a.d; i += kStep16) {
    for (int v = 0; v < kVecs16; ++v) {
      V16 rv[NR];
      for (int k = 0; k < NR; ++k) {
        rv[k] = hn::PromoteTo(d16, hn::LoadU(d8, r + k * r_stride + i + v * kW16));
      }
      for (int j = 0; j < NQ; ++j) {
        const V16 qv = hn::LoadU(d16, a.q16 + j * a.q_stride + i + v * kW16);
        for (int k = 0; k < NR; ++k) {
          acc[j][k][v] = MulAccumulatePairs(qv, rv[k], acc[j][k][v], acc1[j][k][v]);
        }
      }
    }
  }
  HWY_ALIGN int32_t lanes[2 * kVecs16 * kW32];
  for (int j = 0; j < NQ; ++j) {
    const int16_t* q = a.q16 + j * a.q_stride;
    for (int k = 0; k < NR; ++k) {
      for (int v = 0; v < kVecs16; ++v) {
        hn::Store(acc[j][k][v], d32, lanes + (2 * v) * kW32);
        hn::Store(acc1[j][k][v], d32, lanes + (2 * v + 1) * kW32);
      }
      a.out[j * a.out_stride + k] = Int8Finish(lanes, 2 * kVecs16 * kW32, q, r + k * r_stride, i,
                                               a.d, a.scale, a.q_scales[j]);
    }
  }
}

// ---- pairs: two queries' eight lanes in 16 logical lanes -------------------------------
// Lanes 0-7 are query 2p's, 8-15 query 2p + 1's, for one row, whose block of eight elements
// goes to both halves: one AVX-512 register (the row's block broadcast), two AVX2 ones, four
// NEON ones. A 4-pair x 6-row tile keeps 24 AVX-512 registers of sums busy for 10 loads per
// eight elements (where rows' 4 x 3 keeps 12 for 7); with eight floats a register its sums
// would not fit, so PrepareQueries takes pairs on 16-float targets only.
using DP = hn::CappedTag<float, 2 * kLanes>;
using VP = hn::Vec<DP>;
constexpr int kWP = static_cast<int>(hn::MaxLanes(DP()));
constexpr int kVecsP = 2 * kLanes / kWP;

// Vector u of a row's block of eight elements at p, as the pairs' lanes read it.
template <class T>
HWY_INLINE VP PairRow(const T* p, int u) {
  const DP dp;
#if HWY_TARGET != HWY_SCALAR  // (which has no Combine, and one lane)
  if constexpr (kWP > kLanes) {
    const hn::Half<DP> dh;
    const auto half = LoadFloats(dh, p);
    return hn::Combine(dp, half, half);
  }
#endif
  return LoadFloats(dp, p + (u * kWP) % kLanes);
}

// One block: the rows' elements at rp[k], the pairs' at offset `at` (padded already).
template <int NP, int NR>
HWY_INLINE void PairsBlock(const TileArgs& a, const float* const* rp, int at,
                           VP (&acc)[NP][NR][kVecsP]) {
  const DP dp;
  for (int u = 0; u < kVecsP; ++u) {
    VP qv[NP];
    for (int p = 0; p < NP; ++p) qv[p] = hn::LoadU(dp, a.pairs + p * a.pairs_stride + at + u * kWP);
    for (int k = 0; k < NR; ++k) {
      const VP rv = PairRow(rp[k], u);
      for (int p = 0; p < NP; ++p) acc[p][k][u] = LaneMulAdd(qv[p], rv, acc[p][k][u]);
    }
  }
}

template <int NP, int NR>
HWY_NOINLINE void TilePairs(const TileArgs& a, const float* r, int r_stride) {
  const DP dp;
  VP acc[NP][NR][kVecsP];
  for (int p = 0; p < NP; ++p) {
    for (int k = 0; k < NR; ++k) {
      for (int u = 0; u < kVecsP; ++u) {
        acc[p][k][u] =
            a.first ? hn::Zero(dp) : hn::LoadU(dp, a.lanes + p * a.lanes_stride + k * 16 + u * kWP);
      }
    }
  }
  const int full = a.i1 - (a.i1 - a.i0) % kLanes;  // a pass ends on a block unless at d
  const float* rp[NR];
  for (int i = a.i0; i < full; i += kLanes) {
    for (int k = 0; k < NR; ++k) rp[k] = r + k * r_stride + i;
    PairsBlock<NP, NR>(a, rp, 2 * i, acc);
  }
  if (a.i1 == a.d && full < a.d) {  // the zero-padded tail
    HWY_ALIGN float pad[NR][kLanes];
    for (int k = 0; k < NR; ++k) {
      PadTail(r + k * r_stride, full, a.d, pad[k]);
      rp[k] = pad[k];
    }
    PairsBlock<NP, NR>(a, rp, 2 * full, acc);
  }
  HWY_ALIGN float lanes[2 * kLanes];
  for (int p = 0; p < NP; ++p) {
    for (int k = 0; k < NR; ++k) {
      float* const to = a.i1 < a.d ? a.lanes + p * a.lanes_stride + k * 16 : lanes;
      for (int u = 0; u < kVecsP; ++u) hn::StoreU(acc[p][k][u], dp, to + u * kWP);
      if (a.i1 < a.d) continue;
      a.out[(2 * p) * a.out_stride + k] = ReduceLanes(lanes);
      a.out[(2 * p + 1) * a.out_stride + k] = ReduceLanes(lanes + kLanes);
    }
  }
}

#undef BSF_VPR_VNNI

}  // namespace HWY_NAMESPACE
}  // namespace kernels
}  // namespace bsf_vpr
HWY_AFTER_NAMESPACE();

#endif  // BSF_VPR_DISTANCE_TILES_INL_H_
