// Training-free single-reference likelihood (paper, Eq. obsLikelihoods and placeMatch).
//
//   P(D^u | X = i)  proportional to  P(D_i | X = i) / P(D_i | X != i)
//   P(D_i | X = i)  proportional to  c_i = #{ j : D_i <= D_j }            (rank count)
//   P(D_i | X != i) = N(D_i; mu, sigma^2), mu and sigma^2 the mean and variance of D^u
//
// so log P(D^u | X = i) = log c_i + (D_i - mu)^2 / (2 sigma^2) + const.
#pragma once

#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/selection.h"

namespace bsf_vpr {

enum class LikelihoodVariant {
  // Exactly the paper: the Gaussian non-match term is two-sided.
  kTwoSided,
  // A distance above the mean gets no extra credit for lying far out in the upper tail:
  // (D_i - mu) is replaced by min(D_i - mu, 0). On real data, outlier places (dark tunnel
  // frames, for instance) lie far above the mean of every query's distances, and with the
  // two-sided term their huge (D_i - mu)^2 / 2 sigma^2 outweighs log c_i <= log N, so the
  // argmax collapses onto them. See docs/method.md, "Likelihood variants".
  kOneSided,
};

// The variants' names (likelihood).
const EnumNames<LikelihoodVariant>& LikelihoodVariantNames();
// A name of LikelihoodVariantNames(); throws std::invalid_argument naming the choices otherwise.
LikelihoodVariant ParseLikelihoodVariant(const std::string& name);
std::string ToString(LikelihoodVariant variant);

struct LikelihoodOptions {
  LikelihoodVariant variant = LikelihoodVariant::kOneSided;
};

// c_k = #{ j : values[j] >= values[k] } for each k, in O(N) (a radix sort; NaN not
// allowed). `counts` has `count` slots.
void RankCounts(const float* values, int count, int* counts);

// log P(D^u | X = place_ids[k]) for the k = 0..count-1 places the set covers, written to
// `log_likelihood` (count slots, caller-owned). The values are shifted by a constant so that
// the mean of exp(log_likelihood) over the covered places is 1: a place the set does not
// cover gets log-likelihood 0 from it (neutral: the set neither favours nor penalises it
// against the places it covers). Zero variance makes the Gaussian term 0 (no NaN).
void PlaceMatchLogLikelihood(const SetDistances& d, const LikelihoodOptions& options,
                             double* log_likelihood);
// The same with the set's statistics already computed (ComputeDistanceStats(d)).
void PlaceMatchLogLikelihood(const SetDistances& d, const DistanceStats& stats,
                             const LikelihoodOptions& options, double* log_likelihood);
// log c_k + (e_k)^2 / (2 sigma^2) without the shift: PlaceMatchLogLikelihood minus one
// constant per set. Enough where the constant cancels (a set that covers every place once).
void UnnormalisedPlaceMatchLogLikelihood(const SetDistances& d, const DistanceStats& stats,
                                         const LikelihoodOptions& options, double* log_likelihood);

}  // namespace bsf_vpr
