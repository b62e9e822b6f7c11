// exp over arrays of doubles for the likelihoods, the fusion and the filter: one algorithm
// (Cody-Waite reduction by ln 2, a degree-13 Taylor polynomial in Horner form, multiplies and
// adds rounded one by one, scaling by two powers of two) run 8 lanes at a time with AVX-512,
// 4 with AVX2, one at a time otherwise, so every kernel gives the same bits. Within 2 ulp of
// the exact value for results in the normal range; 0 below -745.13, +inf above 709.78, NaN
// for NaN. Dispatched with the distance kernels (kernels::Active(), kernels::Force()).
#pragma once

#include <Eigen/Core>

namespace bsf_vpr {
namespace kernels {

// out[k] = exp(x[k] - shift) for k < n; out may be x.
void Exp(const double* x, Eigen::Index n, double shift, double* out);

// sum_k exp(x[k] - shift), the terms added in a fixed order (eight running sums, lane j
// taking k = j mod 8, then added as the distance kernels add their lanes).
double SumExp(const double* x, Eigen::Index n, double shift);

}  // namespace kernels

// exp(a - shift) as a new array.
inline Eigen::ArrayXd ExpOf(const Eigen::ArrayXd& a, double shift = 0.0) {
  Eigen::ArrayXd out(a.size());
  kernels::Exp(a.data(), a.size(), shift, out.data());
  return out;
}

}  // namespace bsf_vpr
