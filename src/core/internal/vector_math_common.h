// The scalar parts of the vector math kernels (vector_math.cpp, compiled once per target): the
// algorithms' constants, the fixed reduction of the eight lanes and the temporal filter's
// places at the route's ends, where a step reads past it. Included by vector_math.cpp alone.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>

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
constexpr double kRoundShift = 1.5 * kTwo52;        // v + it - it: v rounded to an integer
// 1 / k! for k = 13 down to 2 (the Horner steps for r^k / k!; then r and 1).
constexpr double kInvFactorial[12] = {1.0 / 6227020800.0, 1.0 / 479001600.0, 1.0 / 39916800.0,
                                      1.0 / 3628800.0,    1.0 / 362880.0,    1.0 / 40320.0,
                                      1.0 / 5040.0,       1.0 / 720.0,       1.0 / 120.0,
                                      1.0 / 24.0,         1.0 / 6.0,         1.0 / 2.0};

// log(x) = e ln 2 + log(1 + f), x = 2^e m with m = 1 + f in [sqrt(1/2), sqrt(2)) (f exact).
// As fdlibm: with s = f / (2 + f) (|s| <= 0.1716) and hfsq = f^2 / 2,
// log(1 + f) = 2 atanh(s) = f - hfsq + s (hfsq + R), R = sum_k 2 s^2k / (2k + 1), k = 1..10
// (the first term left out is below 1e-18 of the result); f carries the bulk exactly.
constexpr double kLogCoefficient[10] = {2.0 / 21, 2.0 / 19, 2.0 / 17, 2.0 / 15, 2.0 / 13,
                                        2.0 / 11, 2.0 / 9,  2.0 / 7,  2.0 / 5,  2.0 / 3};
constexpr double kSqrtHalf = 0.70710678118654752440;
constexpr double kTwo54 = 18014398509481984.0;  // 2^54: subnormals scaled into the normal range
constexpr uint64_t kTwo52Bits = 0x4330000000000000ull;     // 2^52 as bits
constexpr uint64_t kMantissaBits = 0x000fffffffffffffull;  // a double's fraction field
constexpr uint64_t kOneBits = 0x3ff0000000000000ull;       // 1.0 as bits

// The lanes' sums added as the distance kernels add theirs.
inline double ReduceLanesDouble(const double* l) {
  return ((l[0] + l[4]) + (l[1] + l[5])) + ((l[2] + l[6]) + (l[3] + l[7]));
}

// The places whose every step reads inside [0, n), from a multiple of 8 on (so that a
// block of 8 places holds lanes 0-7 of the sum): [*first, *last).
inline void StepInterior(Eigen::Index n, int taps, long s_lo, Eigen::Index* first,
                         Eigen::Index* last) {
  const Eigen::Index from = std::max<Eigen::Index>(0, s_lo + taps - 1);
  *first = std::min<Eigen::Index>(n, (from + kLanes - 1) / kLanes * kLanes);
  *last = std::max(*first, std::min<Eigen::Index>(n, n + s_lo));
}

// The places of [j0, j1) one at a time, the taps whose index lies outside [0, n) left out,
// each added to its lane of the sum (lane j mod 8): moved[j] = sum_k w[k] p[j - s_lo - k] in
// k order from 0, the operations of the interior's vectors.
inline void StepSumsAtEdge(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                           Eigen::Index j0, Eigen::Index j1, double* moved, double* lanes) {
  for (Eigen::Index j = j0; j < j1; ++j) {
    double acc = 0.0;
    for (int k = 0; k < taps; ++k) {
      const Eigen::Index i = j - s_lo - k;
      if (i >= 0 && i < n) acc = acc + w[k] * p[i];
    }
    moved[j] = acc;
    lanes[j % kLanes] += moved[j];
  }
}

}  // namespace
}  // namespace kernels
}  // namespace bsf_vpr
