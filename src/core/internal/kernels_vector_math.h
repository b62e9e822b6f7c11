// The kernels of vector_math.h (exp, its sum, the filter's step sums): the same operations in
// the same order per lane, scalar, AVX2 and AVX-512, so that they give the same bits. Included by
// distance_kernels.cpp alone (compiled with -ffp-contract=off: no multiply-add is fused behind the
// code's back).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

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

// The lanes' sums added as the distance kernels add theirs.
inline double ReduceLanesDouble(const double* l) {
  return ((l[0] + l[4]) + (l[1] + l[5])) + ((l[2] + l[6]) + (l[3] + l[7]));
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

// exp(x[k] - shift) into out[k] (if out is not null), and their sum in eight lanes (lane
// k mod 8) added in the fixed tree.
double ExpPortable(const double* x, Eigen::Index n, double shift, double* out) {
  double lanes[kLanes] = {};
  for (Eigen::Index k = 0; k < n; ++k) {
    const double y = ExpOne(x[k] - shift);
    if (out != nullptr) out[k] = y;
    lanes[k % kLanes] += y;
  }
  return ReduceLanesDouble(lanes);
}

// log(x) = e ln 2 + log(1 + f), x = 2^e m with m = 1 + f in [sqrt(1/2), sqrt(2)) (f exact).
// As fdlibm: with s = f / (2 + f) (|s| <= 0.1716) and hfsq = f^2 / 2,
// log(1 + f) = 2 atanh(s) = f - hfsq + s (hfsq + R), R = sum_k 2 s^2k / (2k + 1), k = 1..10
// (the first term left out is below 1e-18 of the result); f carries the bulk exactly.
constexpr double kLogCoefficient[10] = {2.0 / 21, 2.0 / 19, 2.0 / 17, 2.0 / 15, 2.0 / 13,
                                        2.0 / 11, 2.0 / 9,  2.0 / 7,  2.0 / 5,  2.0 / 3};
constexpr double kSqrtHalf = 0.70710678118654752440;
constexpr double kTwo54 = 18014398509481984.0;  // 2^54: subnormals scaled into the normal range

inline double LogOne(double x) {
  if (std::isnan(x) || x < 0) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0) return -INFINITY;
  if (x == INFINITY) return INFINITY;
  double bias = 1023.0;
  if (x < std::numeric_limits<double>::min()) {
    x *= kTwo54;
    bias += 54.0;
  }
  uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  // The exponent field as a double (its integer in the low bits of 2^52's), and m in [1, 2).
  uint64_t e_bits = (bits >> 52) | 0x4330000000000000ull;
  double e;
  std::memcpy(&e, &e_bits, sizeof e);
  e = (e - kTwo52) - bias;
  const uint64_t m_bits = (bits & 0x000fffffffffffffull) | 0x3ff0000000000000ull;
  double m;
  std::memcpy(&m, &m_bits, sizeof m);
  if (m > 2.0 * kSqrtHalf) {
    m = m * 0.5;
    e = e + 1.0;
  }
  const double f = m - 1.0;
  const double s = f / (2.0 + f);
  const double z = s * s;
  double r = kLogCoefficient[0];
  for (int k = 1; k < 10; ++k) r = r * z + kLogCoefficient[k];
  r = r * z;
  const double hfsq = 0.5 * f * f;
  return e * kLn2Hi - ((hfsq - (s * (hfsq + r) + e * kLn2Lo)) - f);
}

void LogPortable(const double* x, Eigen::Index n, double* out) {
  for (Eigen::Index k = 0; k < n; ++k) out[k] = LogOne(x[k]);
}

// moved[j] = sum_k w[k] p[j - s_lo - k] over the k whose index is in [0, n), in k order from 0.
inline double StepSumOne(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                         Eigen::Index j) {
  double acc = 0.0;
  for (int k = 0; k < taps; ++k) {
    const Eigen::Index i = j - s_lo - k;
    if (i >= 0 && i < n) acc = acc + w[k] * p[i];
  }
  return acc;
}

// The places whose every step reads inside [0, n), from a multiple of 8 on (so that a
// vector of 8 places holds lanes 0-7 of the sum): [*first, *last).
inline void StepInterior(Eigen::Index n, int taps, long s_lo, Eigen::Index* first,
                         Eigen::Index* last) {
  const Eigen::Index from = std::max<Eigen::Index>(0, s_lo + taps - 1);
  *first = std::min<Eigen::Index>(n, (from + kLanes - 1) / kLanes * kLanes);
  *last = std::max(*first, std::min<Eigen::Index>(n, n + s_lo));
}

// The places of [j0, j1) one at a time, each added to its lane of the sum (lane j mod 8).
inline void StepSumsScalar(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                           Eigen::Index j0, Eigen::Index j1, double* moved, double* lanes) {
  for (Eigen::Index j = j0; j < j1; ++j) {
    moved[j] = StepSumOne(p, n, w, taps, s_lo, j);
    lanes[j % kLanes] += moved[j];
  }
}

double StepSumsPortable(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                        double* moved) {
  double lanes[kLanes] = {};
  StepSumsScalar(p, n, w, taps, s_lo, 0, n, moved, lanes);
  return ReduceLanesDouble(lanes);
}

// x[k] = (a x[k] + b) l[k], and their sum in eight lanes (lane k mod 8).
inline void ScaleShiftMultiplyScalar(double* x, Eigen::Index k0, Eigen::Index n, double a, double b,
                                     const double* l, double* lanes) {
  for (Eigen::Index k = k0; k < n; ++k) {
    x[k] = (a * x[k] + b) * l[k];
    lanes[k % kLanes] += x[k];
  }
}
double ScaleShiftMultiplyPortable(double* x, Eigen::Index n, double a, double b, const double* l) {
  double lanes[kLanes] = {};
  ScaleShiftMultiplyScalar(x, 0, n, a, b, l, lanes);
  return ReduceLanesDouble(lanes);
}

// y[k] += a[j] x[j][k] for j = 0, 1, ..., m - 1 in turn (each product rounded, then added).
void AddScaledPortable(double* y, const double* const* x, const double* a, int m, Eigen::Index n) {
  for (int j = 0; j < m; ++j) {
    for (Eigen::Index k = 0; k < n; ++k) y[k] += a[j] * x[j][k];
  }
}

// ---- lane sums of floats in double (the selection's and the fusion's mean and deviation) ---
// Lane j adds the elements k = j (mod 8) in increasing k; the tail's elements go to lanes
// 0, 1, ... as the scalar loop puts them.
inline void SumTail(const float* v, int full, int n, double* sum, float* low) {
  for (int k = full; k < n; ++k) {
    sum[k - full] += v[k];
    if (low != nullptr) low[k - full] = std::min(low[k - full], v[k]);
  }
}
double LaneSumPortable(const float* v, int n, float* low) {
  const int full = n - n % kLanes;
  double sum[kLanes] = {};
  for (int k = 0; k < full; k += kLanes) {
    for (int j = 0; j < kLanes; ++j) {
      sum[j] += v[k + j];
      if (low != nullptr) low[j] = std::min(low[j], v[k + j]);
    }
  }
  SumTail(v, full, n, sum, low);
  return ReduceLanesDouble(sum);
}
double LaneDifferenceSumPortable(const float* d, const float* c, int n, float* out) {
  const int full = n - n % kLanes;
  double sum[kLanes] = {};
  for (int k = 0; k < n; ++k) out[k] = d[k] - c[k];
  for (int k = 0; k < full; k += kLanes) {
    for (int j = 0; j < kLanes; ++j) sum[j] += out[k + j];
  }
  SumTail(out, full, n, sum, nullptr);
  return ReduceLanesDouble(sum);
}
inline void SquaresTail(const float* v, int full, int n, double mean, double* ss) {
  for (int k = full; k < n; ++k) {
    const double e = v[k] - mean;
    ss[k - full] += e * e;
  }
}
double LaneSquaredDeviationsPortable(const float* v, int n, double mean) {
  const int full = n - n % kLanes;
  double ss[kLanes] = {};
  for (int k = 0; k < full; k += kLanes) {
    for (int j = 0; j < kLanes; ++j) {
      const double e = v[k + j] - mean;
      ss[j] += e * e;
    }
  }
  SquaresTail(v, full, n, mean, ss);
  return ReduceLanesDouble(ss);
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

// Two registers of four: lanes 0-3 and 4-7 of the portable order.
BSF_VPR_AVX2 double ExpKernelAvx2(const double* x, Eigen::Index n, double shift, double* out) {
  const __m256d s = _mm256_set1_pd(shift);
  __m256d lo = _mm256_setzero_pd(), hi = _mm256_setzero_pd();
  Eigen::Index k = 0;
  for (; k + kLanes <= n; k += kLanes) {
    const __m256d a = ExpAvx2(_mm256_sub_pd(_mm256_loadu_pd(x + k), s));
    const __m256d b = ExpAvx2(_mm256_sub_pd(_mm256_loadu_pd(x + k + 4), s));
    if (out != nullptr) {
      _mm256_storeu_pd(out + k, a);
      _mm256_storeu_pd(out + k + 4, b);
    }
    lo = _mm256_add_pd(lo, a);
    hi = _mm256_add_pd(hi, b);
  }
  double lanes[kLanes];
  _mm256_storeu_pd(lanes, lo);
  _mm256_storeu_pd(lanes + 4, hi);
  for (; k < n; ++k) {
    const double y = ExpOne(x[k] - shift);
    if (out != nullptr) out[k] = y;
    lanes[k % kLanes] += y;
  }
  return ReduceLanesDouble(lanes);
}

BSF_VPR_AVX2 inline __m256d StepFourAvx2(const double* p, const double* w, int taps, long s_lo,
                                         Eigen::Index j) {
  __m256d acc = _mm256_setzero_pd();
  for (int k = 0; k < taps; ++k) {
    acc =
        _mm256_add_pd(acc, _mm256_mul_pd(_mm256_set1_pd(w[k]), _mm256_loadu_pd(p + j - s_lo - k)));
  }
  return acc;
}

// Two registers of four: lanes 0-3 and 4-7 of the portable order.
BSF_VPR_AVX2 double StepSumsAvx2(const double* p, Eigen::Index n, const double* w, int taps,
                                 long s_lo, double* moved) {
  Eigen::Index first, last;
  StepInterior(n, taps, s_lo, &first, &last);
  double lanes[kLanes] = {};
  StepSumsScalar(p, n, w, taps, s_lo, 0, first, moved, lanes);
  __m256d lo = _mm256_loadu_pd(lanes), hi = _mm256_loadu_pd(lanes + 4);
  Eigen::Index j = first;
  for (; j + kLanes <= last; j += kLanes) {
    const __m256d a = StepFourAvx2(p, w, taps, s_lo, j), b = StepFourAvx2(p, w, taps, s_lo, j + 4);
    _mm256_storeu_pd(moved + j, a);
    _mm256_storeu_pd(moved + j + 4, b);
    lo = _mm256_add_pd(lo, a);
    hi = _mm256_add_pd(hi, b);
  }
  _mm256_storeu_pd(lanes, lo);
  _mm256_storeu_pd(lanes + 4, hi);
  StepSumsScalar(p, n, w, taps, s_lo, j, n, moved, lanes);
  return ReduceLanesDouble(lanes);
}

BSF_VPR_AVX2 void LogKernelAvx2(const double* x, Eigen::Index n, double* out) {
  const __m256d tiny = _mm256_set1_pd(std::numeric_limits<double>::min());
  Eigen::Index k = 0;
  for (; k + 4 <= n; k += 4) {
    const __m256d v = _mm256_loadu_pd(x + k);
    // Lanes outside the positive normal numbers (and NaN) are left to the scalar code.
    const __m256d normal = _mm256_and_pd(_mm256_cmp_pd(v, tiny, _CMP_GE_OQ),
                                         _mm256_cmp_pd(v, _mm256_set1_pd(INFINITY), _CMP_LT_OQ));
    if (_mm256_movemask_pd(normal) != 0xf) {
      for (int j = 0; j < 4; ++j) out[k + j] = LogOne(x[k + j]);
      continue;
    }
    const __m256i bits = _mm256_castpd_si256(v);
    const __m256d e_field = _mm256_castsi256_pd(
        _mm256_or_si256(_mm256_srli_epi64(bits, 52), _mm256_set1_epi64x(0x4330000000000000ll)));
    __m256d e =
        _mm256_sub_pd(_mm256_sub_pd(e_field, _mm256_set1_pd(kTwo52)), _mm256_set1_pd(1023.0));
    __m256d m = _mm256_castsi256_pd(
        _mm256_or_si256(_mm256_and_si256(bits, _mm256_set1_epi64x(0x000fffffffffffffll)),
                        _mm256_set1_epi64x(0x3ff0000000000000ll)));
    const __m256d big = _mm256_cmp_pd(m, _mm256_set1_pd(2.0 * kSqrtHalf), _CMP_GT_OQ);
    m = _mm256_blendv_pd(m, _mm256_mul_pd(m, _mm256_set1_pd(0.5)), big);
    e = _mm256_blendv_pd(e, _mm256_add_pd(e, _mm256_set1_pd(1.0)), big);
    const __m256d f = _mm256_sub_pd(m, _mm256_set1_pd(1.0));
    const __m256d s = _mm256_div_pd(f, _mm256_add_pd(_mm256_set1_pd(2.0), f));
    const __m256d z = _mm256_mul_pd(s, s);
    __m256d r = _mm256_set1_pd(kLogCoefficient[0]);
    for (int j = 1; j < 10; ++j) {
      r = _mm256_add_pd(_mm256_mul_pd(r, z), _mm256_set1_pd(kLogCoefficient[j]));
    }
    r = _mm256_mul_pd(r, z);
    const __m256d hfsq = _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(0.5), f), f);
    const __m256d inner = _mm256_add_pd(_mm256_mul_pd(s, _mm256_add_pd(hfsq, r)),
                                        _mm256_mul_pd(e, _mm256_set1_pd(kLn2Lo)));
    const __m256d y = _mm256_sub_pd(_mm256_mul_pd(e, _mm256_set1_pd(kLn2Hi)),
                                    _mm256_sub_pd(_mm256_sub_pd(hfsq, inner), f));
    _mm256_storeu_pd(out + k, y);
  }
  for (; k < n; ++k) out[k] = LogOne(x[k]);
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

// One register: lane j holds the portable lane j.
BSF_VPR_AVX512 double ExpKernelAvx512(const double* x, Eigen::Index n, double shift, double* out) {
  const __m512d s = _mm512_set1_pd(shift);
  __m512d sum = _mm512_setzero_pd();
  Eigen::Index k = 0;
  for (; k + kLanes <= n; k += kLanes) {
    const __m512d y = ExpAvx512(_mm512_sub_pd(_mm512_loadu_pd(x + k), s));
    if (out != nullptr) _mm512_storeu_pd(out + k, y);
    sum = _mm512_add_pd(sum, y);
  }
  double lanes[kLanes];
  _mm512_storeu_pd(lanes, sum);
  for (; k < n; ++k) {
    const double y = ExpOne(x[k] - shift);
    if (out != nullptr) out[k] = y;
    lanes[k % kLanes] += y;
  }
  return ReduceLanesDouble(lanes);
}
// One register: lane j holds the portable lane j.
BSF_VPR_AVX512 double StepSumsAvx512(const double* p, Eigen::Index n, const double* w, int taps,
                                     long s_lo, double* moved) {
  Eigen::Index first, last;
  StepInterior(n, taps, s_lo, &first, &last);
  double lanes[kLanes] = {};
  StepSumsScalar(p, n, w, taps, s_lo, 0, first, moved, lanes);
  __m512d sum = _mm512_loadu_pd(lanes);
  Eigen::Index j = first;
  for (; j + kLanes <= last; j += kLanes) {
    __m512d acc = _mm512_setzero_pd();
    for (int k = 0; k < taps; ++k) {
      acc = _mm512_add_pd(acc,
                          _mm512_mul_pd(_mm512_set1_pd(w[k]), _mm512_loadu_pd(p + j - s_lo - k)));
    }
    _mm512_storeu_pd(moved + j, acc);
    sum = _mm512_add_pd(sum, acc);
  }
  _mm512_storeu_pd(lanes, sum);
  StepSumsScalar(p, n, w, taps, s_lo, j, n, moved, lanes);
  return ReduceLanesDouble(lanes);
}
BSF_VPR_AVX512 void LogKernelAvx512(const double* x, Eigen::Index n, double* out) {
  const __m512d tiny = _mm512_set1_pd(std::numeric_limits<double>::min());
  Eigen::Index k = 0;
  for (; k + 8 <= n; k += 8) {
    const __m512d v = _mm512_loadu_pd(x + k);
    // Lanes outside the positive normal numbers (and NaN) are left to the scalar code.
    const __mmask8 normal = _mm512_cmp_pd_mask(v, tiny, _CMP_GE_OQ) &
                            _mm512_cmp_pd_mask(v, _mm512_set1_pd(INFINITY), _CMP_LT_OQ);
    if (normal != 0xff) {
      for (int j = 0; j < 8; ++j) out[k + j] = LogOne(x[k + j]);
      continue;
    }
    const __m512i bits = _mm512_castpd_si512(v);
    const __m512d e_field = _mm512_castsi512_pd(
        _mm512_or_si512(_mm512_srli_epi64(bits, 52), _mm512_set1_epi64(0x4330000000000000ll)));
    __m512d e =
        _mm512_sub_pd(_mm512_sub_pd(e_field, _mm512_set1_pd(kTwo52)), _mm512_set1_pd(1023.0));
    __m512d m = _mm512_castsi512_pd(
        _mm512_or_si512(_mm512_and_si512(bits, _mm512_set1_epi64(0x000fffffffffffffll)),
                        _mm512_set1_epi64(0x3ff0000000000000ll)));
    const __mmask8 big = _mm512_cmp_pd_mask(m, _mm512_set1_pd(2.0 * kSqrtHalf), _CMP_GT_OQ);
    m = _mm512_mask_mul_pd(m, big, m, _mm512_set1_pd(0.5));
    e = _mm512_mask_add_pd(e, big, e, _mm512_set1_pd(1.0));
    const __m512d f = _mm512_sub_pd(m, _mm512_set1_pd(1.0));
    const __m512d s = _mm512_div_pd(f, _mm512_add_pd(_mm512_set1_pd(2.0), f));
    const __m512d z = _mm512_mul_pd(s, s);
    __m512d r = _mm512_set1_pd(kLogCoefficient[0]);
    for (int j = 1; j < 10; ++j) {
      r = _mm512_add_pd(_mm512_mul_pd(r, z), _mm512_set1_pd(kLogCoefficient[j]));
    }
    r = _mm512_mul_pd(r, z);
    const __m512d hfsq = _mm512_mul_pd(_mm512_mul_pd(_mm512_set1_pd(0.5), f), f);
    const __m512d inner = _mm512_add_pd(_mm512_mul_pd(s, _mm512_add_pd(hfsq, r)),
                                        _mm512_mul_pd(e, _mm512_set1_pd(kLn2Lo)));
    const __m512d y = _mm512_sub_pd(_mm512_mul_pd(e, _mm512_set1_pd(kLn2Hi)),
                                    _mm512_sub_pd(_mm512_sub_pd(hfsq, inner), f));
    _mm512_storeu_pd(out + k, y);
  }
  for (; k < n; ++k) out[k] = LogOne(x[k]);
}
#pragma GCC diagnostic pop
// ScaleShiftMultiply a register of lanes at a time, each lane's operations those of the
// portable loop: lanes 0-3 and 4-7 of the sum in two registers (AVX2), all eight in one
// (AVX-512).
BSF_VPR_AVX2 double ScaleShiftMultiplyAvx2(double* x, Eigen::Index n, double a, double b,
                                           const double* l) {
  const __m256d va = _mm256_set1_pd(a), vb = _mm256_set1_pd(b);
  __m256d lo = _mm256_setzero_pd(), hi = _mm256_setzero_pd();
  Eigen::Index k = 0;
  for (; k + kLanes <= n; k += kLanes) {
    const __m256d y0 = _mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(va, _mm256_loadu_pd(x + k)), vb),
                                     _mm256_loadu_pd(l + k));
    const __m256d y1 =
        _mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(va, _mm256_loadu_pd(x + k + 4)), vb),
                      _mm256_loadu_pd(l + k + 4));
    _mm256_storeu_pd(x + k, y0);
    _mm256_storeu_pd(x + k + 4, y1);
    lo = _mm256_add_pd(lo, y0);
    hi = _mm256_add_pd(hi, y1);
  }
  double lanes[kLanes];
  _mm256_storeu_pd(lanes, lo);
  _mm256_storeu_pd(lanes + 4, hi);
  ScaleShiftMultiplyScalar(x, k, n, a, b, l, lanes);
  return ReduceLanesDouble(lanes);
}
BSF_VPR_AVX512 double ScaleShiftMultiplyAvx512(double* x, Eigen::Index n, double a, double b,
                                               const double* l) {
  const __m512d va = _mm512_set1_pd(a), vb = _mm512_set1_pd(b);
  __m512d sum = _mm512_setzero_pd();
  Eigen::Index k = 0;
  for (; k + kLanes <= n; k += kLanes) {
    const __m512d y = _mm512_mul_pd(_mm512_add_pd(_mm512_mul_pd(va, _mm512_loadu_pd(x + k)), vb),
                                    _mm512_loadu_pd(l + k));
    _mm512_storeu_pd(x + k, y);
    sum = _mm512_add_pd(sum, y);
  }
  double lanes[kLanes];
  _mm512_storeu_pd(lanes, sum);
  ScaleShiftMultiplyScalar(x, k, n, a, b, l, lanes);
  return ReduceLanesDouble(lanes);
}
// The same a register of lanes at a time, each lane's operations those of the portable loop.
BSF_VPR_AVX2 void AddScaledAvx2(double* y, const double* const* x, const double* a, int m,
                                Eigen::Index n) {
  Eigen::Index k = 0;
  for (; k + 4 <= n; k += 4) {
    __m256d v = _mm256_loadu_pd(y + k);
    for (int j = 0; j < m; ++j) {
      v = _mm256_add_pd(v, _mm256_mul_pd(_mm256_set1_pd(a[j]), _mm256_loadu_pd(x[j] + k)));
    }
    _mm256_storeu_pd(y + k, v);
  }
  for (; k < n; ++k) {
    for (int j = 0; j < m; ++j) y[k] += a[j] * x[j][k];
  }
}
BSF_VPR_AVX512 void AddScaledAvx512(double* y, const double* const* x, const double* a, int m,
                                    Eigen::Index n) {
  Eigen::Index k = 0;
  for (; k + 8 <= n; k += 8) {
    __m512d v = _mm512_loadu_pd(y + k);
    for (int j = 0; j < m; ++j) {
      v = _mm512_add_pd(v, _mm512_mul_pd(_mm512_set1_pd(a[j]), _mm512_loadu_pd(x[j] + k)));
    }
    _mm512_storeu_pd(y + k, v);
  }
  for (; k < n; ++k) {
    for (int j = 0; j < m; ++j) y[k] += a[j] * x[j][k];
  }
}
// The lane sums: lanes 0-3 in one register and 4-7 in another (AVX2), all eight in one
// (AVX-512); the minimum's lanes as the scalar std::min keeps them (min(v, low): low when
// either is NaN or both are zeros, as std::min(low, v)).
BSF_VPR_AVX2 double LaneSumAvx2(const float* v, int n, float* low) {
  const int full = n - n % kLanes;
  __m256d lo = _mm256_setzero_pd(), hi = _mm256_setzero_pd();
  __m256 m = low != nullptr ? _mm256_loadu_ps(low) : _mm256_setzero_ps();
  for (int k = 0; k < full; k += kLanes) {
    const __m256 x = _mm256_loadu_ps(v + k);
    lo = _mm256_add_pd(lo, _mm256_cvtps_pd(_mm256_castps256_ps128(x)));
    hi = _mm256_add_pd(hi, _mm256_cvtps_pd(_mm256_extractf128_ps(x, 1)));
    if (low != nullptr) m = _mm256_min_ps(x, m);
  }
  double sum[kLanes];
  _mm256_storeu_pd(sum, lo);
  _mm256_storeu_pd(sum + 4, hi);
  if (low != nullptr) _mm256_storeu_ps(low, m);
  SumTail(v, full, n, sum, low);
  return ReduceLanesDouble(sum);
}
BSF_VPR_AVX2 double LaneDifferenceSumAvx2(const float* d, const float* c, int n, float* out) {
  const int full = n - n % kLanes;
  __m256d lo = _mm256_setzero_pd(), hi = _mm256_setzero_pd();
  for (int k = 0; k < full; k += kLanes) {
    const __m256 x = _mm256_sub_ps(_mm256_loadu_ps(d + k), _mm256_loadu_ps(c + k));
    _mm256_storeu_ps(out + k, x);
    lo = _mm256_add_pd(lo, _mm256_cvtps_pd(_mm256_castps256_ps128(x)));
    hi = _mm256_add_pd(hi, _mm256_cvtps_pd(_mm256_extractf128_ps(x, 1)));
  }
  for (int k = full; k < n; ++k) out[k] = d[k] - c[k];
  double sum[kLanes];
  _mm256_storeu_pd(sum, lo);
  _mm256_storeu_pd(sum + 4, hi);
  SumTail(out, full, n, sum, nullptr);
  return ReduceLanesDouble(sum);
}
BSF_VPR_AVX2 double LaneSquaredDeviationsAvx2(const float* v, int n, double mean) {
  const int full = n - n % kLanes;
  const __m256d mu = _mm256_set1_pd(mean);
  __m256d lo = _mm256_setzero_pd(), hi = _mm256_setzero_pd();
  for (int k = 0; k < full; k += kLanes) {
    const __m256 x = _mm256_loadu_ps(v + k);
    const __m256d el = _mm256_sub_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(x)), mu);
    const __m256d eh = _mm256_sub_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(x, 1)), mu);
    lo = _mm256_add_pd(lo, _mm256_mul_pd(el, el));
    hi = _mm256_add_pd(hi, _mm256_mul_pd(eh, eh));
  }
  double ss[kLanes];
  _mm256_storeu_pd(ss, lo);
  _mm256_storeu_pd(ss + 4, hi);
  SquaresTail(v, full, n, mean, ss);
  return ReduceLanesDouble(ss);
}
// GCC 12's _mm512_cvtps_pd starts from an undefined register, which it then warns of.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
BSF_VPR_AVX512 double LaneSumAvx512(const float* v, int n, float* low) {
  const int full = n - n % kLanes;
  __m512d acc = _mm512_setzero_pd();
  __m256 m = low != nullptr ? _mm256_loadu_ps(low) : _mm256_setzero_ps();
  for (int k = 0; k < full; k += kLanes) {
    const __m256 x = _mm256_loadu_ps(v + k);
    acc = _mm512_add_pd(acc, _mm512_cvtps_pd(x));
    if (low != nullptr) m = _mm256_min_ps(x, m);
  }
  double sum[kLanes];
  _mm512_storeu_pd(sum, acc);
  if (low != nullptr) _mm256_storeu_ps(low, m);
  SumTail(v, full, n, sum, low);
  return ReduceLanesDouble(sum);
}
BSF_VPR_AVX512 double LaneDifferenceSumAvx512(const float* d, const float* c, int n, float* out) {
  const int full = n - n % kLanes;
  __m512d acc = _mm512_setzero_pd();
  for (int k = 0; k < full; k += kLanes) {
    const __m256 x = _mm256_sub_ps(_mm256_loadu_ps(d + k), _mm256_loadu_ps(c + k));
    _mm256_storeu_ps(out + k, x);
    acc = _mm512_add_pd(acc, _mm512_cvtps_pd(x));
  }
  for (int k = full; k < n; ++k) out[k] = d[k] - c[k];
  double sum[kLanes];
  _mm512_storeu_pd(sum, acc);
  SumTail(out, full, n, sum, nullptr);
  return ReduceLanesDouble(sum);
}
BSF_VPR_AVX512 double LaneSquaredDeviationsAvx512(const float* v, int n, double mean) {
  const int full = n - n % kLanes;
  const __m512d mu = _mm512_set1_pd(mean);
  __m512d acc = _mm512_setzero_pd();
  for (int k = 0; k < full; k += kLanes) {
    const __m512d e = _mm512_sub_pd(_mm512_cvtps_pd(_mm256_loadu_ps(v + k)), mu);
    acc = _mm512_add_pd(acc, _mm512_mul_pd(e, e));
  }
  double ss[kLanes];
  _mm512_storeu_pd(ss, acc);
  SquaresTail(v, full, n, mean, ss);
  return ReduceLanesDouble(ss);
}
#pragma GCC diagnostic pop
#endif

}  // namespace
}  // namespace kernels
}  // namespace bsf_vpr
