// The exp kernels (vector_math.h): the same operations in the same order per lane, scalar,
// AVX2 and AVX-512, so that they give the same bits. Included by distance_kernels.cpp alone
// (compiled with -ffp-contract=off: no multiply-add is fused behind the code's back).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "src/core/internal/kernel_common.h"

namespace bsf_vpr {
namespace kernels {
namespace {

// exp(x) = 2^n exp(r), n = round(x log2 e), r = x - n ln2 with ln2 split in two (the high
// part has 21 trailing zero bits, so n * kLn2Hi is exact for |n| < 2^11).
constexpr double kLog2e = 1.4426950408889634074;
constexpr double kLn2Hi = 6.93147180369123816490e-01;
constexpr double kLn2Lo = 1.90821492927058770002e-10;
constexpr double kExpMax = 709.782712893383973096;  // above: +inf
constexpr double kExpMin = -745.13321910194110842;  // below: 0
constexpr double kTwo52 = 4503599627370496.0;       // 2^52
// 1 / k! for k = 13 down to 2 (the Horner steps for r^k / k!; then r and 1).
constexpr double kInvFactorial[12] = {1.0 / 6227020800.0, 1.0 / 479001600.0, 1.0 / 39916800.0,
                                      1.0 / 3628800.0,    1.0 / 362880.0,    1.0 / 40320.0,
                                      1.0 / 5040.0,       1.0 / 720.0,       1.0 / 120.0,
                                      1.0 / 24.0,         1.0 / 6.0,         1.0 / 2.0};

// 2^k for an integral k in [-1022, 1023] given as a double.
inline double TwoTo(double k) {
  const double biased = (k + 1023.0) + kTwo52;  // the integer k + 1023 in the low bits
  uint64_t bits;
  std::memcpy(&bits, &biased, sizeof bits);
  bits <<= 52;
  double out;
  std::memcpy(&out, &bits, sizeof out);
  return out;
}

inline double ExpOne(double x) {
  if (std::isnan(x)) return x;
  if (x > kExpMax) return INFINITY;
  if (x < kExpMin) return 0.0;
  const double n = std::nearbyint(x * kLog2e);
  const double r = (x - n * kLn2Hi) - n * kLn2Lo;
  double p = kInvFactorial[0];
  for (int k = 1; k < 12; ++k) p = p * r + kInvFactorial[k];
  p = p * r + 1.0;
  p = p * r + 1.0;
  // 2^n in two factors, each a normal number for n in [-1075, 1024].
  const double n1 = std::floor(n * 0.5);
  return (p * TwoTo(n1)) * TwoTo(n - n1);
}

void ExpPortable(const double* x, Eigen::Index n, double shift, double* out) {
  for (Eigen::Index k = 0; k < n; ++k) out[k] = ExpOne(x[k] - shift);
}

// The lanes' sums added as the distance kernels add theirs.
inline double ReduceLanesDouble(const double* l) {
  return ((l[0] + l[4]) + (l[1] + l[5])) + ((l[2] + l[6]) + (l[3] + l[7]));
}

double SumExpPortable(const double* x, Eigen::Index n, double shift) {
  double lanes[kLanes] = {};
  for (Eigen::Index k = 0; k < n; ++k) lanes[k % kLanes] += ExpOne(x[k] - shift);
  return ReduceLanesDouble(lanes);
}

#ifdef BSF_VPR_HAVE_AVX2_KERNEL
BSF_VPR_AVX2 inline __m256d TwoToAvx2(__m256d k) {
  const __m256d biased =
      _mm256_add_pd(_mm256_add_pd(k, _mm256_set1_pd(1023.0)), _mm256_set1_pd(kTwo52));
  return _mm256_castsi256_pd(_mm256_slli_epi64(_mm256_castpd_si256(biased), 52));
}

BSF_VPR_AVX2 inline __m256d ExpAvx2(__m256d x) {
  const __m256d xc =
      _mm256_min_pd(_mm256_max_pd(x, _mm256_set1_pd(kExpMin)), _mm256_set1_pd(kExpMax));
  const __m256d n = _mm256_round_pd(_mm256_mul_pd(xc, _mm256_set1_pd(kLog2e)),
                                    _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  const __m256d r = _mm256_sub_pd(_mm256_sub_pd(xc, _mm256_mul_pd(n, _mm256_set1_pd(kLn2Hi))),
                                  _mm256_mul_pd(n, _mm256_set1_pd(kLn2Lo)));
  __m256d p = _mm256_set1_pd(kInvFactorial[0]);
  for (int k = 1; k < 12; ++k) {
    p = _mm256_add_pd(_mm256_mul_pd(p, r), _mm256_set1_pd(kInvFactorial[k]));
  }
  const __m256d one = _mm256_set1_pd(1.0);
  p = _mm256_add_pd(_mm256_mul_pd(p, r), one);
  p = _mm256_add_pd(_mm256_mul_pd(p, r), one);
  const __m256d n1 = _mm256_floor_pd(_mm256_mul_pd(n, _mm256_set1_pd(0.5)));
  __m256d y = _mm256_mul_pd(_mm256_mul_pd(p, TwoToAvx2(n1)), TwoToAvx2(_mm256_sub_pd(n, n1)));
  y = _mm256_blendv_pd(y, _mm256_set1_pd(INFINITY),
                       _mm256_cmp_pd(x, _mm256_set1_pd(kExpMax), _CMP_GT_OQ));
  y = _mm256_blendv_pd(y, _mm256_setzero_pd(),
                       _mm256_cmp_pd(x, _mm256_set1_pd(kExpMin), _CMP_LT_OQ));
  return _mm256_blendv_pd(y, x, _mm256_cmp_pd(x, x, _CMP_UNORD_Q));
}

BSF_VPR_AVX2 void ExpKernelAvx2(const double* x, Eigen::Index n, double shift, double* out) {
  const __m256d s = _mm256_set1_pd(shift);
  Eigen::Index k = 0;
  for (; k + 4 <= n; k += 4) {
    _mm256_storeu_pd(out + k, ExpAvx2(_mm256_sub_pd(_mm256_loadu_pd(x + k), s)));
  }
  for (; k < n; ++k) out[k] = ExpOne(x[k] - shift);
}

// Two registers of four: lanes 0-3 and 4-7 of the portable order.
BSF_VPR_AVX2 double SumExpAvx2(const double* x, Eigen::Index n, double shift) {
  const __m256d s = _mm256_set1_pd(shift);
  __m256d lo = _mm256_setzero_pd(), hi = _mm256_setzero_pd();
  Eigen::Index k = 0;
  for (; k + 8 <= n; k += 8) {
    lo = _mm256_add_pd(lo, ExpAvx2(_mm256_sub_pd(_mm256_loadu_pd(x + k), s)));
    hi = _mm256_add_pd(hi, ExpAvx2(_mm256_sub_pd(_mm256_loadu_pd(x + k + 4), s)));
  }
  double lanes[kLanes];
  _mm256_storeu_pd(lanes, lo);
  _mm256_storeu_pd(lanes + 4, hi);
  for (; k < n; ++k) lanes[k % kLanes] += ExpOne(x[k] - shift);
  return ReduceLanesDouble(lanes);
}

// GCC 12's masked AVX-512 intrinsics start from an undefined register, which it then warns of.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
BSF_VPR_AVX512 inline __m512d TwoToAvx512(__m512d k) {
  const __m512d biased =
      _mm512_add_pd(_mm512_add_pd(k, _mm512_set1_pd(1023.0)), _mm512_set1_pd(kTwo52));
  return _mm512_castsi512_pd(_mm512_slli_epi64(_mm512_castpd_si512(biased), 52));
}

BSF_VPR_AVX512 inline __m512d ExpAvx512(__m512d x) {
  const __m512d xc =
      _mm512_min_pd(_mm512_max_pd(x, _mm512_set1_pd(kExpMin)), _mm512_set1_pd(kExpMax));
  const __m512d n = _mm512_roundscale_pd(_mm512_mul_pd(xc, _mm512_set1_pd(kLog2e)),
                                         _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  const __m512d r = _mm512_sub_pd(_mm512_sub_pd(xc, _mm512_mul_pd(n, _mm512_set1_pd(kLn2Hi))),
                                  _mm512_mul_pd(n, _mm512_set1_pd(kLn2Lo)));
  __m512d p = _mm512_set1_pd(kInvFactorial[0]);
  for (int k = 1; k < 12; ++k) {
    p = _mm512_add_pd(_mm512_mul_pd(p, r), _mm512_set1_pd(kInvFactorial[k]));
  }
  const __m512d one = _mm512_set1_pd(1.0);
  p = _mm512_add_pd(_mm512_mul_pd(p, r), one);
  p = _mm512_add_pd(_mm512_mul_pd(p, r), one);
  const __m512d n1 = _mm512_roundscale_pd(_mm512_mul_pd(n, _mm512_set1_pd(0.5)),
                                          _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  __m512d y = _mm512_mul_pd(_mm512_mul_pd(p, TwoToAvx512(n1)), TwoToAvx512(_mm512_sub_pd(n, n1)));
  y = _mm512_mask_mov_pd(y, _mm512_cmp_pd_mask(x, _mm512_set1_pd(kExpMax), _CMP_GT_OQ),
                         _mm512_set1_pd(INFINITY));
  y = _mm512_mask_mov_pd(y, _mm512_cmp_pd_mask(x, _mm512_set1_pd(kExpMin), _CMP_LT_OQ),
                         _mm512_setzero_pd());
  return _mm512_mask_mov_pd(y, _mm512_cmp_pd_mask(x, x, _CMP_UNORD_Q), x);
}

BSF_VPR_AVX512 void ExpKernelAvx512(const double* x, Eigen::Index n, double shift, double* out) {
  const __m512d s = _mm512_set1_pd(shift);
  Eigen::Index k = 0;
  for (; k + 8 <= n; k += 8) {
    _mm512_storeu_pd(out + k, ExpAvx512(_mm512_sub_pd(_mm512_loadu_pd(x + k), s)));
  }
  for (; k < n; ++k) out[k] = ExpOne(x[k] - shift);
}

// One register: lane j holds the portable lane j.
BSF_VPR_AVX512 double SumExpAvx512(const double* x, Eigen::Index n, double shift) {
  const __m512d s = _mm512_set1_pd(shift);
  __m512d sum = _mm512_setzero_pd();
  Eigen::Index k = 0;
  for (; k + 8 <= n; k += 8) {
    sum = _mm512_add_pd(sum, ExpAvx512(_mm512_sub_pd(_mm512_loadu_pd(x + k), s)));
  }
  double lanes[kLanes];
  _mm512_storeu_pd(lanes, sum);
  for (; k < n; ++k) lanes[k % kLanes] += ExpOne(x[k] - shift);
  return ReduceLanesDouble(lanes);
}
#pragma GCC diagnostic pop
#endif

}  // namespace
}  // namespace kernels
}  // namespace bsf_vpr
