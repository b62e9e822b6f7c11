// Vector math over arrays of doubles, for the likelihoods, the fusion and the filter: exp,
// its sum, log, the filter's step sums and weighted sums of columns. Each is one algorithm, its
// multiplies and adds rounded one by one in a fixed order, written once over Google Highway
// (vector_math.cpp) and run 8 lanes at a time with AVX-512, 4 with AVX2, 2 with NEON and one at a
// time on the portable kernel, so every kernel gives the same bits. Dispatched with the distance
// kernels (kernels::Active(), kernels::Force()).
//
// exp: Cody-Waite reduction by ln 2, a degree-13 Taylor polynomial in Horner form, scaling by
// two powers of two. Within 2 ulp of the exact value for results in the normal range; 0 below
// -745.13, +inf above 709.78, NaN for NaN.
// log: x = 2^e (1 + f) with 1 + f in [sqrt(1/2), sqrt(2)), log(1 + f) as fdlibm forms it
// from s = f / (2 + f) (a degree-10 series in s^2), e ln 2 added in two parts. Within 2 ulp; -inf
// at 0, NaN below 0 and for NaN, +inf at +inf; subnormals scaled first.
#pragma once

#include <Eigen/Core>

namespace bsf_vpr {
namespace kernels {

// out[k] = exp(x[k] - shift) for k < n (out may be x, or null: the sum alone); returns
// their sum as SumExp adds it.
double Exp(const double* x, Eigen::Index n, double shift, double* out);

// out[k] = log(x[k]) for k < n; out may be x.
void Log(const double* x, Eigen::Index n, double* out);

// sum_k exp(x[k] - shift), the terms added in a fixed order (eight running sums, lane j
// taking k = j mod 8, then added as the distance kernels add their lanes).
double SumExp(const double* x, Eigen::Index n, double shift);

// The temporal filter's motion step: moved[j] = sum_k w[k] p[j - s_lo - k] for j < n, over
// the k (0 <= k < taps) whose index lies in [0, n), added in k order starting from 0 (mass
// moved past either end is lost). moved must not overlap p. Returns sum_j moved[j], added in
// the fixed order SumExp adds its terms.
double StepSums(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                double* moved);

// x[k] = (a x[k] + b) l[k] for k < n, each multiply and add rounded in that order (the
// filter's prior, normalised, times a likelihood); returns sum_k x[k], added in the fixed
// order SumExp adds its terms.
double ScaleShiftMultiply(double* x, Eigen::Index n, double a, double b, const double* l);

// y[k] += a[j] x[j][k] for k < n and j = 0, 1, ..., m - 1 in that order, each product
// rounded and then added (as Eigen's y += a * x, one column after another, computes it).
void AddScaled(double* y, const double* const* x, const double* a, int m, Eigen::Index n);

// Sums of n floats in double in eight lanes (lane j adds v[k] for k = j mod 8 in increasing
// k), the lanes then added as SumExp adds its own: the selection's and the fusion's means
// and deviations, the same bits on every kernel.
// sum_k v[k]; with `low` (eight floats, set by the caller), low[j] = std::min(low[j], v[k])
// over lane j's elements too.
double LaneSum(const float* v, int n, float* low);
// out[k] = d[k] - c[k] (float), and sum_k out[k].
double LaneDifferenceSum(const float* d, const float* c, int n, float* out);
// sum_k (v[k] - mean)^2, each difference and square rounded in double.
double LaneSquaredDeviations(const float* v, int n, double mean);

}  // namespace kernels

// log(a) as a new array.
inline Eigen::ArrayXd LogOf(const Eigen::ArrayXd& a) {
  Eigen::ArrayXd out(a.size());
  kernels::Log(a.data(), a.size(), out.data());
  return out;
}

// exp(a - shift) as a new array.
inline Eigen::ArrayXd ExpOf(const Eigen::ArrayXd& a, double shift = 0.0) {
  Eigen::ArrayXd out(a.size());
  kernels::Exp(a.data(), a.size(), shift, out.data());
  return out;
}

}  // namespace bsf_vpr
