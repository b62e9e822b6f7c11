// The AVX-512 kernel (AVX-512 F and DQ): two queries' eight lanes in one __m512, float32
// batches only; CpuHasAvx512(). With AVX-512 VNNI (and BW) the int8 rows' integer inner
// products too (CpuHasAvx512Vnni()). Included by distance_kernels.cpp alone.
#pragma once

#include "src/core/internal/kernels_avx2.h"

namespace bsf_vpr {
namespace kernels {
namespace {

#ifdef BSF_VPR_HAVE_AVX2_KERNEL
// ---- AVX-512 kernel: two queries' eight lanes in one __m512 -----------------------------
// The same eight lanes, order and FMA as the AVX2 kernel, so the bits are the same: the low
// half of a register holds query 2p's lanes for a row and the high half query 2p + 1's, the
// row's eight elements broadcast to both halves. A 4-pair x 6-row tile keeps 24 registers of
// sums (384 pairs' lanes) busy for 10 loads per eight elements, where the AVX2 tile of 4 x 3
// keeps 12 for 7 loads. Float32 rows in batches only; the rest is the AVX2 kernel's. In a
// large batch the tiles read their rows packed (TilePairsPackedAvx512).

// GCC 12's _mm512_broadcast_f32x8 starts from an undefined register, which it then warns of.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// A pair tile's sums at the start of a pass: zero, or the lanes the last pass stored (pair
// p's lanes for row k: 16 floats at a.lanes + p * a.lanes_stride + k * 16).
template <int NP, int NR>
BSF_VPR_AVX512 inline __attribute__((always_inline)) void StartPairLanes(const TileArgs& a,
                                                                         __m512 (&acc)[NP][NR]) {
  for (int p = 0; p < NP; ++p) {
    for (int k = 0; k < NR; ++k) {
      acc[p][k] = a.first ? _mm512_setzero_ps()
                          : _mm512_loadu_ps(a.lanes + p * a.lanes_stride + k * 2 * kLanes);
    }
  }
}
// At the end of a pass: before the row's end, the lanes stored for the next pass; at it,
// ReduceLanes of both halves in the register, in its order: lanes j + (j + 4) (128-bit
// quarters swapped), then pairs of those, then the two pairs (a float sum's operands
// commute, so the bits are ReduceLanes's); query 2p's sum lands in lane 0, 2p + 1's in 8.
template <int NP, int NR>
BSF_VPR_AVX512 inline __attribute__((always_inline)) void FinishPairLanes(
    const TileArgs& a, const __m512 (&acc)[NP][NR]) {
  if (a.i1 < a.d) {
    for (int p = 0; p < NP; ++p) {
      for (int k = 0; k < NR; ++k) {
        _mm512_storeu_ps(a.lanes + p * a.lanes_stride + k * 2 * kLanes, acc[p][k]);
      }
    }
    return;
  }
  for (int p = 0; p < NP; ++p) {
    for (int k = 0; k < NR; ++k) {
      __m512 s = acc[p][k];
      s = _mm512_add_ps(s, _mm512_shuffle_f32x4(s, s, _MM_SHUFFLE(2, 3, 0, 1)));
      s = _mm512_add_ps(s, _mm512_permute_ps(s, _MM_SHUFFLE(2, 3, 0, 1)));
      s = _mm512_add_ps(s, _mm512_permute_ps(s, _MM_SHUFFLE(1, 0, 3, 2)));
      a.out[(2 * p) * a.out_stride + k] = _mm512_cvtss_f32(s);
      a.out[(2 * p + 1) * a.out_stride + k] = _mm_cvtss_f32(_mm512_extractf32x4_ps(s, 2));
    }
  }
}

template <int NP, int NR>
BSF_VPR_AVX512 void TilePairsAvx512(const TileArgs& a, const float* r, int r_stride) {
  __m512 acc[NP][NR];
  StartPairLanes(a, acc);
  const int full = a.i1 - (a.i1 - a.i0) % kLanes;  // a pass ends on a block unless at d
  for (int i = a.i0; i < full; i += kLanes) {
    __m512 qv[NP];
    for (int p = 0; p < NP; ++p) qv[p] = _mm512_loadu_ps(a.pairs + p * a.pairs_stride + 2 * i);
    for (int k = 0; k < NR; ++k) {
      const __m512 rv = _mm512_broadcast_f32x8(_mm256_loadu_ps(r + k * r_stride + i));
      for (int p = 0; p < NP; ++p) acc[p][k] = _mm512_fmadd_ps(qv[p], rv, acc[p][k]);
    }
  }
  if (a.i1 == a.d && full < a.d) {  // the zero-padded tail: the pairs are padded already
    alignas(32) float pad[kLanes];
    __m512 qv[NP];
    for (int p = 0; p < NP; ++p) qv[p] = _mm512_loadu_ps(a.pairs + p * a.pairs_stride + 2 * full);
    for (int k = 0; k < NR; ++k) {
      PadTail(r + k * r_stride, full, a.d, pad);
      const __m512 rv = _mm512_broadcast_f32x8(_mm256_load_ps(pad));
      for (int p = 0; p < NP; ++p) acc[p][k] = _mm512_fmadd_ps(qv[p], rv, acc[p][k]);
    }
  }
  FinishPairLanes(a, acc);
}
// The same tile over rows packed by PackRowTilesAvx512: row k's elements [8 b, 8 b + 8) at
// r + (b * NR + k) * 8, the last block zero-padded, so that a tile reads one stream (its rows
// one after another would be NR streams, each starting cold at every pass). The same
// elements in the same order: the same bits as TilePairsAvx512.
template <int NP, int NR>
BSF_VPR_AVX512 void TilePairsPackedAvx512(const TileArgs& a, const float* r) {
  __m512 acc[NP][NR];
  StartPairLanes(a, acc);
  const int end = a.i1 < a.d ? a.i1 : (a.d + kLanes - 1) / kLanes * kLanes;  // padded at d
  const float* block = r + static_cast<size_t>(a.i0 / kLanes) * NR * kLanes;
  const float* pair = a.pairs + 2 * static_cast<size_t>(a.i0);
  for (int i = a.i0; i < end; i += kLanes, block += NR * kLanes, pair += 2 * kLanes) {
    __m512 qv[NP];
    for (int p = 0; p < NP; ++p) qv[p] = _mm512_loadu_ps(pair + p * a.pairs_stride);
    for (int k = 0; k < NR; ++k) {
      const __m512 rv = _mm512_broadcast_f32x8(_mm256_load_ps(block + k * kLanes));
      for (int p = 0; p < NP; ++p) acc[p][k] = _mm512_fmadd_ps(qv[p], rv, acc[p][k]);
    }
  }
  FinishPairLanes(a, acc);
}
// Rows [b0, b0 + NR * tiles) of `rows` (d floats each) laid out for TilePairsPackedAvx512<., NR>:
// tile t's block b (its NR rows' elements [8 b, 8 b + 8), zero-padded past d) at
// packed + (t * blocks + b) * NR * 8, blocks = ceil(d / 8); `packed` on 32 bytes.
template <int NR>
BSF_VPR_AVX512 void PackRowTilesAvx512(const float* rows, int d, int b0, int tiles, float* packed) {
  const int blocks = (d + kLanes - 1) / kLanes, full = d / kLanes;
  for (int t = 0; t < tiles; ++t) {
    const float* row = rows + static_cast<size_t>(b0 + t * NR) * d;
    float* to = packed + static_cast<size_t>(t) * blocks * NR * kLanes;
    for (int b = 0; b < full; ++b, to += NR * kLanes) {
      for (int k = 0; k < NR; ++k) {
        _mm256_store_ps(to + k * kLanes,
                        _mm256_loadu_ps(row + static_cast<size_t>(k) * d + b * kLanes));
      }
    }
    if (full < blocks) {
      for (int k = 0; k < NR; ++k)
        PadTail(row + static_cast<size_t>(k) * d, full * kLanes, d, to + k * kLanes);
    }
  }
}

#pragma GCC diagnostic pop

bool CpuHasAvx512() {
  return CpuHasAvx2() && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
}

// ---- AVX-512 VNNI: int8 rows, 32 products a register ---------------------------------
// The row's int8 values widened to int16 and multiplied with the query's int16 levels by
// VPDPWSSD, which adds each pair of neighbouring products into an int32 lane: 32 products
// per instruction, where the AVX2 kernel's madd and add do 16 in two. Every lane takes d / 16
// products, half of the AVX2 kernel's d / 8 that QueryLevels bounds, so no lane overflows;
// the sum is exact in integers, the same as every other kernel's.
template <int NQ, int NR>
BSF_VPR_AVX512_VNNI void TileInt8Vnni(const TileArgs& a, const int8_t* r, int r_stride) {
  __m512i acc[NQ][NR];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) acc[j][k] = _mm512_setzero_si512();
  }
  int i = 0;
  for (; i + 32 <= a.d; i += 32) {
    __m512i rv[NR];
    for (int k = 0; k < NR; ++k) {
      rv[k] = _mm512_cvtepi8_epi16(
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r + k * r_stride + i)));
    }
    for (int j = 0; j < NQ; ++j) {
      const __m512i qv = _mm512_loadu_si512(a.q16 + j * a.q_stride + i);
      for (int k = 0; k < NR; ++k) acc[j][k] = _mm512_dpwssd_epi32(acc[j][k], qv, rv[k]);
    }
  }
  alignas(64) int32_t lanes[16];
  for (int j = 0; j < NQ; ++j) {
    const int16_t* q = a.q16 + j * a.q_stride;
    for (int k = 0; k < NR; ++k) {
      _mm512_store_si512(lanes, acc[j][k]);
      a.out[j * a.out_stride + k] =
          Int8Finish(lanes, 16, q, r + k * r_stride, i, a.d, a.scale, a.q_scales[j]);
    }
  }
}

bool CpuHasAvx512Vnni() {
  return CpuHasAvx512() && __builtin_cpu_supports("avx512bw") &&
         __builtin_cpu_supports("avx512vnni");
}
#else
bool CpuHasAvx512() { return false; }
bool CpuHasAvx512Vnni() { return false; }
#endif

}  // namespace
}  // namespace kernels
}  // namespace bsf_vpr
