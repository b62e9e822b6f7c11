// The AVX2 kernel (x86: AVX2, FMA, F16C): eight lanes as one __m256, FMA, and the int8
// kernel with madd; CpuHasAvx2(). Included by distance_kernels.cpp alone.
#pragma once

#include "src/core/internal/kernel_common.h"

namespace bsf_vpr {
namespace kernels {
namespace {

// ---- AVX2 kernel: eight lanes as one __m256, FMA ------------------------------------------

#ifdef BSF_VPR_HAVE_AVX2_KERNEL
BSF_VPR_AVX2 inline __m256 Load8(const float* p) { return _mm256_loadu_ps(p); }
BSF_VPR_AVX2 inline __m256 Load8(const uint16_t* p) {
  return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}

template <class T, int NQ, int NR>
BSF_VPR_AVX2 void TileAvx2(const TileArgs& a, const T* r, int r_stride) {
  __m256 acc[NQ][NR];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      acc[j][k] = a.first ? _mm256_setzero_ps()
                          : _mm256_loadu_ps(a.lanes + j * a.lanes_stride + k * kLanes);
    }
  }
  int i = a.i0;
  for (; i + kLanes <= a.i1; i += kLanes) {
    __m256 rv[NR];
    for (int k = 0; k < NR; ++k) rv[k] = Load8(r + k * r_stride + i);
    for (int j = 0; j < NQ; ++j) {
      const __m256 qv = _mm256_loadu_ps(a.q + j * a.q_stride + i);
      for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_fmadd_ps(qv, rv[k], acc[j][k]);
    }
  }
  if (a.i1 < a.d) {
    for (int j = 0; j < NQ; ++j) {
      for (int k = 0; k < NR; ++k)
        _mm256_storeu_ps(a.lanes + j * a.lanes_stride + k * kLanes, acc[j][k]);
    }
    return;
  }
  if (i < a.d) {
    alignas(32) float pad[kLanes];
    __m256 rv[NR];
    for (int k = 0; k < NR; ++k) {
      PadTail(r + k * r_stride, i, a.d, pad);
      rv[k] = _mm256_load_ps(pad);
    }
    for (int j = 0; j < NQ; ++j) {
      PadTail(a.q + j * a.q_stride, i, a.d, pad);
      const __m256 qv = _mm256_load_ps(pad);
      for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_fmadd_ps(qv, rv[k], acc[j][k]);
    }
  }
  alignas(32) float lanes[kLanes];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      _mm256_store_ps(lanes, acc[j][k]);
      a.out[j * a.out_stride + k] = ReduceLanes(lanes);
    }
  }
}

template <int NQ, int NR>
BSF_VPR_AVX2 void TileInt8Avx2(const TileArgs& a, const int8_t* r, int r_stride) {
  __m256i acc[NQ][NR];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_setzero_si256();
  }
  int i = 0;
  for (; i + 16 <= a.d; i += 16) {
    __m256i rv[NR];
    for (int k = 0; k < NR; ++k) {
      rv[k] = _mm256_cvtepi8_epi16(
          _mm_loadu_si128(reinterpret_cast<const __m128i*>(r + k * r_stride + i)));
    }
    for (int j = 0; j < NQ; ++j) {
      const __m256i qv =
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a.q16 + j * a.q_stride + i));
      for (int k = 0; k < NR; ++k) {
        acc[j][k] = _mm256_add_epi32(acc[j][k], _mm256_madd_epi16(qv, rv[k]));
      }
    }
  }
  alignas(32) int32_t lanes[8];
  for (int j = 0; j < NQ; ++j) {
    const int16_t* q = a.q16 + j * a.q_stride;
    for (int k = 0; k < NR; ++k) {
      _mm256_store_si256(reinterpret_cast<__m256i*>(lanes), acc[j][k]);
      a.out[j * a.out_stride + k] =
          Int8Finish(lanes, 8, q, r + k * r_stride, i, a.d, a.scale, a.q_scales[j]);
    }
  }
}

bool CpuHasAvx2() {
  // F16C from CPUID leaf 1 directly: clang before 16 refuses __builtin_cpu_supports("f16c").
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  const bool f16c = __get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_F16C) != 0;
  return f16c && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

#else
bool CpuHasAvx2() { return false; }
#endif

}  // namespace
}  // namespace kernels
}  // namespace bsf_vpr
