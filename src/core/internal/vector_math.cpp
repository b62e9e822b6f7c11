// The kernels of vector_math.h, written once over Google Highway's vector types and compiled
// once per target (foreach_target.h includes this file again for each), dispatched with the
// distance kernels (simd_targets.h). Each is one algorithm whose every multiply and add is
// rounded on its own (no MulAdd; -ffp-contract=off keeps the compiler from fusing the scalar
// target's), run on eight logical lanes (8 / Lanes(d) vectors of a CappedTag<double, 8>): so
// every target gives the same bits. A last, partial block of eight runs zero-padded, its lanes
// past the end masked out of the sums.
#include "src/core/internal/simd_targets.h"  // first: the targets, before any Highway header
//
#include <algorithm>
#include <cstring>
#include <limits>

#include "src/core/internal/vector_math.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "src/core/internal/vector_math.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
//
#include <hwy/highway.h>

#include "src/core/internal/vector_math_common.h"

HWY_BEFORE_NAMESPACE();
namespace bsf_vpr {
namespace kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DD = hn::CappedTag<double, kLanes>;
using VD = hn::Vec<DD>;
using DF = hn::Rebind<float, DD>;  // as many floats as a VD has doubles
using VF = hn::Vec<DF>;
constexpr int kWD = static_cast<int>(hn::MaxLanes(DD()));
constexpr int kVecsD = kLanes / kWD;

HWY_INLINE VD Constant(double c) { return hn::Set(DD(), c); }

// v rounded to an integer, ties to even (as std::nearbyint), for |v| < 2^51: exact, and the
// same on every target (Highway's scalar Round adds 0.5 and truncates, which rounds twice).
HWY_INLINE VD RoundToEven(VD v) {
  return hn::Sub(hn::Add(v, Constant(kRoundShift)), Constant(kRoundShift));
}

// 2^k for an integral k in [-1022, 1023].
HWY_INLINE VD TwoTo(VD k) {
  const hn::RebindToUnsigned<DD> du;
  const VD biased = hn::Add(hn::Add(k, Constant(1023.0)), Constant(kTwo52));
  return hn::BitCast(DD(), hn::ShiftLeft<52>(hn::BitCast(du, biased)));
}

// exp(x) (vector_math.h).
HWY_INLINE VD ExpOf(VD x) {
  const VD xc = hn::Min(hn::Max(x, Constant(kExpMin)), Constant(kExpMax));
  const VD n = RoundToEven(hn::Mul(xc, Constant(kLog2e)));
  const VD r = hn::Sub(hn::Sub(xc, hn::Mul(n, Constant(kLn2Hi))), hn::Mul(n, Constant(kLn2Lo)));
  VD p = Constant(kInvFactorial[0]);
  for (int k = 1; k < 12; ++k) p = hn::Add(hn::Mul(p, r), Constant(kInvFactorial[k]));
  p = hn::Add(hn::Mul(p, r), Constant(1.0));
  p = hn::Add(hn::Mul(p, r), Constant(1.0));
  // 2^n in two factors, each a normal number for n in [-1075, 1024]; floor(n / 2) rounded
  // from n / 2 - 1/4 (exact).
  const VD n1 = RoundToEven(hn::Sub(hn::Mul(n, Constant(0.5)), Constant(0.25)));
  VD y = hn::Mul(hn::Mul(p, TwoTo(n1)), TwoTo(hn::Sub(n, n1)));
  y = hn::IfThenElse(x > Constant(kExpMax), Constant(INFINITY), y);
  y = hn::IfThenElse(x < Constant(kExpMin), hn::Zero(DD()), y);
  return hn::IfThenElse(hn::IsNaN(x), x, y);
}

// log(x) (vector_math.h): subnormals scaled by 2^54 first; -inf at 0, NaN below 0 and for NaN.
HWY_INLINE VD LogOf(VD x0) {
  const DD d;
  const hn::RebindToUnsigned<DD> du;
  const auto tiny = x0 < Constant(std::numeric_limits<double>::min());
  const VD x = hn::IfThenElse(tiny, hn::Mul(x0, Constant(kTwo54)), x0);
  const VD bias = hn::IfThenElse(tiny, Constant(1023.0 + 54.0), Constant(1023.0));
  const auto bits = hn::BitCast(du, x);
  // The exponent field as a double (its integer in the low bits of 2^52's), and m in [1, 2).
  const VD e_field = hn::BitCast(d, hn::Or(hn::ShiftRight<52>(bits), hn::Set(du, kTwo52Bits)));
  VD e = hn::Sub(hn::Sub(e_field, Constant(kTwo52)), bias);
  VD m = hn::BitCast(d, hn::Or(hn::And(bits, hn::Set(du, kMantissaBits)), hn::Set(du, kOneBits)));
  const auto big = m > Constant(2.0 * kSqrtHalf);
  m = hn::IfThenElse(big, hn::Mul(m, Constant(0.5)), m);
  e = hn::IfThenElse(big, hn::Add(e, Constant(1.0)), e);
  const VD f = hn::Sub(m, Constant(1.0));
  const VD s = hn::Div(f, hn::Add(Constant(2.0), f));
  const VD z = hn::Mul(s, s);
  VD r = Constant(kLogCoefficient[0]);
  for (int k = 1; k < 10; ++k) r = hn::Add(hn::Mul(r, z), Constant(kLogCoefficient[k]));
  r = hn::Mul(r, z);
  const VD hfsq = hn::Mul(hn::Mul(Constant(0.5), f), f);
  const VD inner = hn::Add(hn::Mul(s, hn::Add(hfsq, r)), hn::Mul(e, Constant(kLn2Lo)));
  VD y = hn::Sub(hn::Mul(e, Constant(kLn2Hi)), hn::Sub(hn::Sub(hfsq, inner), f));
  y = hn::IfThenElse(x0 == Constant(INFINITY), x0, y);
  y = hn::IfThenElse(x0 == hn::Zero(d), Constant(-INFINITY), y);
  const VD nan = Constant(std::numeric_limits<double>::quiet_NaN());
  return hn::IfThenElse(hn::Or(hn::IsNaN(x0), x0 < hn::Zero(d)), nan, y);
}

// Eight lanes of double sums, lane j in vector j / kWD.
struct LaneSums {
  VD v[kVecsD];
  LaneSums() {
    for (VD& x : v) x = hn::Zero(DD());
  }
  // Adds lanes [0, count) of `y` (vector u at y[u]).
  void Add(const VD* y, int count = kLanes) {
    for (int u = 0; u < kVecsD; ++u) {
      const int in = std::clamp(count - u * kWD, 0, kWD);
      v[u] = in == kWD ? hn::Add(v[u], y[u])
                       : hn::IfThenElse(hn::FirstN(DD(), in), hn::Add(v[u], y[u]), v[u]);
    }
  }
  double Reduce() const {
    HWY_ALIGN double lanes[kLanes];
    for (int u = 0; u < kVecsD; ++u) hn::Store(v[u], DD(), lanes + u * kWD);
    return ReduceLanesDouble(lanes);
  }
};

// Calls block(k, count) for each block of eight elements of [0, n) (count = 8) and the last,
// partial one (count < 8); `block` reads and writes its elements through Blocked.
template <class Block>
HWY_INLINE void ForEachBlock(Eigen::Index n, const Block& block) {
  Eigen::Index k = 0;
  for (; k + kLanes <= n; k += kLanes) block(k, kLanes);
  if (k < n) block(k, static_cast<int>(n - k));
}

// A block's `count` elements of p (zero-padded to eight) as vectors, and back.
template <class T>
struct Blocked {
  HWY_ALIGN T pad[kLanes];
  const T* From(const T* p, int count) {
    if (count == kLanes) return p;
    std::fill(pad, pad + kLanes, T(0));
    std::copy(p, p + count, pad);
    return pad;
  }
};
HWY_INLINE void StoreBlock(const VD* y, int count, double* to) {
  if (count == kLanes) {
    for (int u = 0; u < kVecsD; ++u) hn::StoreU(y[u], DD(), to + u * kWD);
    return;
  }
  HWY_ALIGN double all[kLanes];
  for (int u = 0; u < kVecsD; ++u) hn::Store(y[u], DD(), all + u * kWD);
  std::copy(all, all + count, to);
}

double ExpTarget(const double* x, Eigen::Index n, double shift, double* out) {
  LaneSums sums;
  ForEachBlock(n, [&](Eigen::Index k, int count) {
    Blocked<double> in;
    const double* from = in.From(x + k, count);
    VD y[kVecsD];
    for (int u = 0; u < kVecsD; ++u) {
      y[u] = ExpOf(hn::Sub(hn::LoadU(DD(), from + u * kWD), Constant(shift)));
    }
    if (out != nullptr) StoreBlock(y, count, out + k);
    sums.Add(y, count);
  });
  return sums.Reduce();
}

void LogTarget(const double* x, Eigen::Index n, double* out) {
  ForEachBlock(n, [&](Eigen::Index k, int count) {
    Blocked<double> in;
    const double* from = in.From(x + k, count);
    VD y[kVecsD];
    for (int u = 0; u < kVecsD; ++u) y[u] = LogOf(hn::LoadU(DD(), from + u * kWD));
    StoreBlock(y, count, out + k);
  });
}

double StepSumsTarget(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                      double* moved) {
  Eigen::Index first, last;
  StepInterior(n, taps, s_lo, &first, &last);
  HWY_ALIGN double lanes[kLanes] = {};
  StepSumsAtEdge(p, n, w, taps, s_lo, 0, first, moved, lanes);
  LaneSums sums;
  for (int u = 0; u < kVecsD; ++u) sums.v[u] = hn::Load(DD(), lanes + u * kWD);
  Eigen::Index j = first;
  for (; j + kLanes <= last; j += kLanes) {  // every tap reads inside [0, n)
    VD y[kVecsD];
    for (int u = 0; u < kVecsD; ++u) {
      VD acc = hn::Zero(DD());
      for (int k = 0; k < taps; ++k) {
        acc = hn::Add(acc, hn::Mul(Constant(w[k]), hn::LoadU(DD(), p + j + u * kWD - s_lo - k)));
      }
      y[u] = acc;
    }
    StoreBlock(y, kLanes, moved + j);
    sums.Add(y);
  }
  for (int u = 0; u < kVecsD; ++u) hn::Store(sums.v[u], DD(), lanes + u * kWD);
  StepSumsAtEdge(p, n, w, taps, s_lo, j, n, moved, lanes);
  return ReduceLanesDouble(lanes);
}

double ScaleShiftMultiplyTarget(double* x, Eigen::Index n, double a, double b, const double* l) {
  LaneSums sums;
  ForEachBlock(n, [&](Eigen::Index k, int count) {
    Blocked<double> xs, ls;
    const double* xk = xs.From(x + k, count);
    const double* lk = ls.From(l + k, count);
    VD y[kVecsD];
    for (int u = 0; u < kVecsD; ++u) {
      const VD ax = hn::Mul(Constant(a), hn::LoadU(DD(), xk + u * kWD));
      y[u] = hn::Mul(hn::Add(ax, Constant(b)), hn::LoadU(DD(), lk + u * kWD));
    }
    StoreBlock(y, count, x + k);
    sums.Add(y, count);
  });
  return sums.Reduce();
}

void AddScaledTarget(double* y, const double* const* x, const double* a, int m, Eigen::Index n) {
  ForEachBlock(n, [&](Eigen::Index k, int count) {
    Blocked<double> ys, xs;
    const double* yk = ys.From(y + k, count);
    VD v[kVecsD];
    for (int u = 0; u < kVecsD; ++u) v[u] = hn::LoadU(DD(), yk + u * kWD);
    for (int j = 0; j < m; ++j) {
      const double* xk = xs.From(x[j] + k, count);
      for (int u = 0; u < kVecsD; ++u) {
        v[u] = hn::Add(v[u], hn::Mul(Constant(a[j]), hn::LoadU(DD(), xk + u * kWD)));
      }
    }
    StoreBlock(v, count, y + k);
  });
}

// ---- lane sums of floats in double (the selection's and the fusion's mean and deviation) ---
// Lane j adds the elements k = j (mod 8) in increasing k; the minimum's lanes as std::min(low,
// v) keeps them (v where v < low, else low: low when either is NaN or both are zeros).
double LaneSumTarget(const float* v, int n, float* low) {
  LaneSums sums;
  HWY_ALIGN float lows[kLanes];
  if (low != nullptr) std::copy(low, low + kLanes, lows);
  ForEachBlock(n, [&](Eigen::Index k, int count) {
    Blocked<float> in;
    const float* from = in.From(v + k, count);
    VD y[kVecsD];
    for (int u = 0; u < kVecsD; ++u) {
      const VF f = hn::LoadU(DF(), from + u * kWD);
      y[u] = hn::PromoteTo(DD(), f);
      if (low == nullptr) continue;
      const VF m = hn::Load(DF(), lows + u * kWD);
      const auto in_block = hn::FirstN(DF(), std::clamp(count - u * kWD, 0, kWD));
      hn::Store(hn::IfThenElse(hn::And(in_block, f < m), f, m), DF(), lows + u * kWD);
    }
    sums.Add(y, count);
  });
  if (low != nullptr) std::copy(lows, lows + kLanes, low);
  return sums.Reduce();
}

double LaneDifferenceSumTarget(const float* d, const float* c, int n, float* out) {
  LaneSums sums;
  ForEachBlock(n, [&](Eigen::Index k, int count) {
    Blocked<float> ds, cs;
    const float* dk = ds.From(d + k, count);
    const float* ck = cs.From(c + k, count);
    HWY_ALIGN float diff[kLanes];
    VD y[kVecsD];
    for (int u = 0; u < kVecsD; ++u) {
      const VF f = hn::Sub(hn::LoadU(DF(), dk + u * kWD), hn::LoadU(DF(), ck + u * kWD));
      hn::Store(f, DF(), diff + u * kWD);
      y[u] = hn::PromoteTo(DD(), f);
    }
    std::copy(diff, diff + count, out + k);
    sums.Add(y, count);
  });
  return sums.Reduce();
}

double LaneSquaredDeviationsTarget(const float* v, int n, double mean) {
  LaneSums sums;
  ForEachBlock(n, [&](Eigen::Index k, int count) {
    Blocked<float> in;
    const float* from = in.From(v + k, count);
    VD y[kVecsD];
    for (int u = 0; u < kVecsD; ++u) {
      const VD e = hn::Sub(hn::PromoteTo(DD(), hn::LoadU(DF(), from + u * kWD)), Constant(mean));
      y[u] = hn::Mul(e, e);
    }
    sums.Add(y, count);
  });
  return sums.Reduce();
}

}  // namespace HWY_NAMESPACE
}  // namespace kernels
}  // namespace bsf_vpr
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace bsf_vpr {
namespace kernels {

HWY_EXPORT(ExpTarget);
HWY_EXPORT(LogTarget);
HWY_EXPORT(StepSumsTarget);
HWY_EXPORT(ScaleShiftMultiplyTarget);
HWY_EXPORT(AddScaledTarget);
HWY_EXPORT(LaneSumTarget);
HWY_EXPORT(LaneDifferenceSumTarget);
HWY_EXPORT(LaneSquaredDeviationsTarget);

double Exp(const double* x, Eigen::Index n, double shift, double* out) {
  return BSF_VPR_DISPATCH(ExpTarget)(x, n, shift, out);
}
void Log(const double* x, Eigen::Index n, double* out) { BSF_VPR_DISPATCH(LogTarget)(x, n, out); }
double SumExp(const double* x, Eigen::Index n, double shift) { return Exp(x, n, shift, nullptr); }
double StepSums(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                double* moved) {
  return BSF_VPR_DISPATCH(StepSumsTarget)(p, n, w, taps, s_lo, moved);
}
double ScaleShiftMultiply(double* x, Eigen::Index n, double a, double b, const double* l) {
  return BSF_VPR_DISPATCH(ScaleShiftMultiplyTarget)(x, n, a, b, l);
}
void AddScaled(double* y, const double* const* x, const double* a, int m, Eigen::Index n) {
  BSF_VPR_DISPATCH(AddScaledTarget)(y, x, a, m, n);
}
double LaneSum(const float* v, int n, float* low) {
  return BSF_VPR_DISPATCH(LaneSumTarget)(v, n, low);
}
double LaneDifferenceSum(const float* d, const float* c, int n, float* out) {
  return BSF_VPR_DISPATCH(LaneDifferenceSumTarget)(d, c, n, out);
}
double LaneSquaredDeviations(const float* v, int n, double mean) {
  return BSF_VPR_DISPATCH(LaneSquaredDeviationsTarget)(v, n, mean);
}

}  // namespace kernels
}  // namespace bsf_vpr
#endif  // HWY_ONCE
