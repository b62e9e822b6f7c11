// The AVX-512 kernel (AVX-512 F and DQ), for batches only: float32 batches of 8-31 queries
// with two queries' eight lanes in one __m512, float32 and float16 batches of 32 or more one
// lane at a time as a matrix product; CpuHasAvx512(). With AVX-512 VNNI (and BW) the int8
// rows' integer inner products too (CpuHasAvx512Vnni()). Included by distance_kernels.cpp
// alone.
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
// keeps 12 for 7 loads. Float32 rows in batches of 8 to 31 queries only (larger ones run by
// lane, TileLanesAvx512); the rest is the AVX2 kernel's.

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
// ---- AVX-512 lane-major tiles: one matrix product per lane ------------------------------
// Lane j of a pair (query, row) is the sum, from zero, of one FMA per element i = j (mod 8)
// in increasing i: for each lane, a matrix product of the queries' and the rows' elements of
// that lane, each output accumulated in order. So a tile of kLaneQueries queries x 32 rows
// runs as a matrix product's micro-kernel does: per element, one query element broadcast
// (from memory, into the FMA) against 16 rows' elements in a register, two registers of rows,
// 24 registers of sums. The eight lanes run one after another and are added in ReduceLanes's
// tree: the same bits as the other kernels, with about a third of the pair tiles' load traffic
// per FMA.
constexpr int kLaneQueries = 12;
constexpr int kLaneRows = 32;

// Rows [b0, b0 + count) (count <= 32; d float32 or float16 values each) packed for
// TileLanesAvx512 as floats: lane j's step t (element 8 t + j of each row; zero past d and
// past count) at
// packed + (j * steps + t) * 32, steps = ceil(d / 8). `packed` on 64 bytes. Eight rows at a
// time, each block of eight elements transposed in registers (rows to lanes).
template <class T>
BSF_VPR_AVX512 void PackRowLanesAvx512(const T* rows, int d, int b0, int count, float* packed) {
  const int steps = (d + kLanes - 1) / kLanes, full = d / kLanes;
  alignas(32) float tail[kLaneRows][kLanes] = {};  // each row's last block, zero-padded
  for (int k = 0; k < count && full < steps; ++k) {
    PadTail(rows + static_cast<size_t>(b0 + k) * d, full * kLanes, d, tail[k]);
  }
  for (int g = 0; g < kLaneRows / kLanes; ++g) {
    const T* row[kLanes];
    for (int k = 0; k < kLanes; ++k) {
      const int r = g * kLanes + k;
      row[k] = r < count ? rows + static_cast<size_t>(b0 + r) * d : nullptr;
    }
    for (int t = 0; t < steps; ++t) {
      __m256 v[kLanes];
      for (int k = 0; k < kLanes; ++k) {
        v[k] = row[k] == nullptr ? _mm256_setzero_ps()
               : t < full        ? Load8(row[k] + t * kLanes)
                                 : _mm256_load_ps(tail[g * kLanes + k]);
      }
      // The 8 x 8 transpose: lane j of rows 0..7 into c[j].
      const __m256 u0 = _mm256_unpacklo_ps(v[0], v[1]), u1 = _mm256_unpackhi_ps(v[0], v[1]);
      const __m256 u2 = _mm256_unpacklo_ps(v[2], v[3]), u3 = _mm256_unpackhi_ps(v[2], v[3]);
      const __m256 u4 = _mm256_unpacklo_ps(v[4], v[5]), u5 = _mm256_unpackhi_ps(v[4], v[5]);
      const __m256 u6 = _mm256_unpacklo_ps(v[6], v[7]), u7 = _mm256_unpackhi_ps(v[6], v[7]);
      const __m256 w0 = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(1, 0, 1, 0));
      const __m256 w1 = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(3, 2, 3, 2));
      const __m256 w2 = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(1, 0, 1, 0));
      const __m256 w3 = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(3, 2, 3, 2));
      const __m256 w4 = _mm256_shuffle_ps(u4, u6, _MM_SHUFFLE(1, 0, 1, 0));
      const __m256 w5 = _mm256_shuffle_ps(u4, u6, _MM_SHUFFLE(3, 2, 3, 2));
      const __m256 w6 = _mm256_shuffle_ps(u5, u7, _MM_SHUFFLE(1, 0, 1, 0));
      const __m256 w7 = _mm256_shuffle_ps(u5, u7, _MM_SHUFFLE(3, 2, 3, 2));
      const __m256 c[kLanes] = {
          _mm256_permute2f128_ps(w0, w4, 0x20), _mm256_permute2f128_ps(w1, w5, 0x20),
          _mm256_permute2f128_ps(w2, w6, 0x20), _mm256_permute2f128_ps(w3, w7, 0x20),
          _mm256_permute2f128_ps(w0, w4, 0x31), _mm256_permute2f128_ps(w1, w5, 0x31),
          _mm256_permute2f128_ps(w2, w6, 0x31), _mm256_permute2f128_ps(w3, w7, 0x31)};
      for (int j = 0; j < kLanes; ++j) {
        _mm256_store_ps(packed + (static_cast<size_t>(j) * steps + t) * kLaneRows + g * kLanes,
                        c[j]);
      }
    }
  }
}

// One lane of a tile: acc[q][h] = sum over the steps, from zero, of a[q] * b[16 h ..] (FMA),
// a stepping by kLaneQueries and b by 32.
BSF_VPR_AVX512 inline __attribute__((always_inline)) void LanePassAvx512(
    const float* a, const float* b, int steps, __m512 (&acc)[kLaneQueries][2]) {
  for (int q = 0; q < kLaneQueries; ++q) acc[q][0] = acc[q][1] = _mm512_setzero_ps();
  for (int t = 0; t < steps; ++t, a += kLaneQueries, b += kLaneRows) {
    const __m512 r0 = _mm512_load_ps(b), r1 = _mm512_load_ps(b + 16);
    for (int q = 0; q < kLaneQueries; ++q) {
      const __m512 x = _mm512_set1_ps(a[q]);
      acc[q][0] = _mm512_fmadd_ps(x, r0, acc[q][0]);
      acc[q][1] = _mm512_fmadd_ps(x, r1, acc[q][1]);
    }
  }
}
BSF_VPR_AVX512 inline __attribute__((always_inline)) void KeepLanesAvx512(
    const __m512 (&acc)[kLaneQueries][2], float* keep) {
  for (int q = 0; q < kLaneQueries; ++q) {
    _mm512_store_ps(keep + q * kLaneRows, acc[q][0]);
    _mm512_store_ps(keep + q * kLaneRows + 16, acc[q][1]);
  }
}
// acc = keep + acc (a float sum's operands commute: the bits of acc + keep).
BSF_VPR_AVX512 inline __attribute__((always_inline)) void AddKeptLanesAvx512(
    const float* keep, __m512 (&acc)[kLaneQueries][2]) {
  for (int q = 0; q < kLaneQueries; ++q) {
    acc[q][0] = _mm512_add_ps(_mm512_load_ps(keep + q * kLaneRows), acc[q][0]);
    acc[q][1] = _mm512_add_ps(_mm512_load_ps(keep + q * kLaneRows + 16), acc[q][1]);
  }
}

// Lanes j and j + 4 of a tile (lane j's step t at a + (j * steps + t) * kLaneQueries, and at
// b + (j * steps + t) * 32): acc = l_j + l_{j+4}, lane j kept in `scratch` meanwhile.
BSF_VPR_AVX512 inline __attribute__((always_inline)) void LanePairAvx512(
    const float* a, const float* b, int steps, int j, float* scratch,
    __m512 (&acc)[kLaneQueries][2]) {
  const auto lane_a = [a, steps](int k) {
    return a + static_cast<size_t>(k) * steps * kLaneQueries;
  };
  const auto lane_b = [b, steps](int k) { return b + static_cast<size_t>(k) * steps * kLaneRows; };
  LanePassAvx512(lane_a(j), lane_b(j), steps, acc);
  KeepLanesAvx512(acc, scratch);
  LanePassAvx512(lane_a(j + 4), lane_b(j + 4), steps, acc);
  AddKeptLanesAvx512(scratch, acc);
}

// The inner products of a panel of queries (packed: lane j's step t at
// a + (j * steps + t) * kLaneQueries) with a panel of rows (PackRowLanesAvx512) into
// out[q * out_stride + r] for q < queries, r < rows: lanes in pairs (0 4, 1 5, 2 6, 3 7),
// added as ((l0 + l4) + (l1 + l5)) + ((l2 + l6) + (l3 + l7)).
BSF_VPR_AVX512 void TileLanesAvx512(const float* a, const float* b, int steps, float* out,
                                    int out_stride, int queries, int rows) {
  __m512 acc[kLaneQueries][2];
  alignas(64) float keep[3][kLaneQueries * kLaneRows];  // two partial sums and a scratch
  LanePairAvx512(a, b, steps, 0, keep[2], acc);         // l0 + l4
  KeepLanesAvx512(acc, keep[0]);
  LanePairAvx512(a, b, steps, 1, keep[2], acc);  // l1 + l5
  AddKeptLanesAvx512(keep[0], acc);              // (l0 + l4) + (l1 + l5)
  KeepLanesAvx512(acc, keep[0]);
  LanePairAvx512(a, b, steps, 2, keep[2], acc);  // l2 + l6
  KeepLanesAvx512(acc, keep[1]);
  LanePairAvx512(a, b, steps, 3, keep[2], acc);  // l3 + l7
  AddKeptLanesAvx512(keep[1], acc);              // (l2 + l6) + (l3 + l7)
  AddKeptLanesAvx512(keep[0], acc);              // the whole tree
  const __mmask16 low = rows >= 16 ? 0xffff : static_cast<__mmask16>((1u << rows) - 1);
  const __mmask16 high = rows >= 32  ? 0xffff
                         : rows > 16 ? static_cast<__mmask16>((1u << (rows - 16)) - 1)
                                     : 0;
  for (int q = 0; q < queries; ++q) {
    _mm512_mask_storeu_ps(out + static_cast<size_t>(q) * out_stride, low, acc[q][0]);
    _mm512_mask_storeu_ps(out + static_cast<size_t>(q) * out_stride + 16, high, acc[q][1]);
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
