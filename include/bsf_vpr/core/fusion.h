// Fusion of reference sets into a decision over places: Bayesian fusion with a prior
// (paper, Eq. bayes, product_form and approach) and the minimum ensemble distance
// (Eq. MED) of Fischer et al.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/likelihood.h"
#include "bsf_vpr/core/selection.h"

namespace bsf_vpr {

// How bsf fuses the sets it relies on (MethodOptions::fusion; docs/method.md, "Fusion that
// adapts").
enum class FusionRule {
  // The default: Bayesian model averaging, over the stream of queries, of three ways the sets
  // of one descriptor may relate to the query: it shows one set's condition, one of them
  // uncertainly (kMixture), or they are independent evidence (the product of all), each
  // weighted by how well it predicted the queries so far (adaptive_fusion.h).
  kAdaptive,
  // Sets of one descriptor are alternative conditions of the query: the query
  // shows (at most) one of them, which one is uncertain, so their likelihoods are mixed,
  // weighted by ConditionWeights (the soft form of the selection rule), with the non-match
  // statistics pooled over the group (FuseMixture). Groups of different descriptors are
  // conditionally independent evidence and multiply.
  kMixture,
  // The paper (Eq. product_form): the selected sets' likelihoods multiply, each with its own
  // statistics.
  kProduct,
};
// The rules' names (fusion).
const EnumNames<FusionRule>& FusionRuleNames();
FusionRule ParseFusionRule(const std::string& name);  // throws naming the choices
std::string ToString(FusionRule rule);

// The outcome of one query under one method.
struct PlaceBelief {
  // The fusion rules fill log_posterior and cost, with the posterior's best place and its
  // log-odds in match and confidence; the decision (decision.h) alone sets accepted and
  // top_places and gives match and confidence their final values.
  int match = -1;  // the place decided on
  // Higher means more sure. Bayesian methods: the log-odds of the match,
  // log P(match) - log P(any other place), from the unnormalised log posterior (stays
  // finite and ordered where the normalised maximum rounds to 1). Distance methods: minus
  // the (mean) distance of the match. +seq methods (any base): the log-odds that the best
  // sequence is not a chance alignment (SequenceMatchLogOdds), comparable across queries.
  double confidence = -std::numeric_limits<double>::infinity();
  // Whether the match may be acted on. Bayesian methods: confidence > h (as log-odds).
  // Distance methods: the match's (mean) distance <= max_match_distance. +seq methods: the
  // sequence's log-odds (SequenceMatchLogOdds) > h. And, where the map calibrated itself,
  // its AcceptanceRule (decision.h). Never true for a non-finite belief.
  bool accepted = false;
  std::vector<int> top_places;    // best first, at most top_k
  Eigen::VectorXd log_posterior;  // N entries, normalised; empty for distance methods
  // Per place, lower is better: -log posterior (Bayesian) or the mean distance (distance
  // methods; +infinity where no used set covers the place). Input of sequence matching.
  Eigen::VectorXd cost;
  Selection selection;         // what the selection rule chose (S, u*), min D^u of every set
  std::vector<int> used_sets;  // the sets the method fused, ascending: S for bsf and
                               // med_selective, all for bayes_full and med, one for nn:/bayes:
                               // (bsf with fusion mixture: every set of non-zero weight)
  // Per set (one entry per set passed in): the weight the method gave it, in [0, 1]. The
  // mixture's ConditionWeights for bsf with fusion mixture; else 1 for a used set, 0 for
  // the others.
  std::vector<double> set_weights;
  // bsf with fusion_joint: the weight of the joint representation's hypothesis (0 without).
  double joint_weight = 0;
  // Bayesian methods with off_map (MethodRunner): the probability that the query shows no
  // place of the map. log_posterior is then the belief given that it shows one, and
  // confidence the log-odds of the match against every other place and "none".
  double off_map_probability = 0;
  // The decision (decision.h): the query's smallest distance to a row showing the match
  // among the sets the method relied on, in the distance's units (MatchDistanceOf); NaN
  // when no such set covers it or no distances were given.
  double match_distance = std::numeric_limits<double>::quiet_NaN();
  int match_distance_set = -1;  // the set it came from (-1: none)
};

// log-odds of the largest entry of unnormalised log-probabilities `log_p` (N >= 1) against
// all the others together; +infinity when no other entry has probability.
double LogOddsOfBest(const Eigen::VectorXd& log_p, int best);

// Indices of the `k` largest entries of `score` (fewer if it is shorter), largest first,
// ties broken towards the smaller index. Entries equal to -infinity are never returned.
std::vector<int> TopK(const Eigen::VectorXd& score, int k);

// Checks a log prior over `num_places` places: right size, no NaN or +inf, some place with
// non-zero probability. Throws std::invalid_argument naming the problem.
void ValidateLogPrior(const Eigen::VectorXd& log_prior, int num_places);

// Bayesian fusion of the sets `use` (indices into `sets`): unnormalised log posterior
// sum_{u in use} log P(D^u | X = i) + log P(X = i). `log_prior` null means uniform.
// Fills log_posterior (normalised), cost, and the posterior's best place and log-odds in
// match and confidence, of `out` (nothing else of `out` is read or written). `set_stats`, if given, holds every set's
// ComputeDistanceStats, already computed for selection (one entry per set of `sets`);
// null computes them for the used sets.
void FuseBayes(const std::vector<SetDistances>& sets, const std::vector<int>& use, int num_places,
               const LikelihoodOptions& likelihood, const Eigen::VectorXd* log_prior,
               PlaceBelief* out, const std::vector<DistanceStats>* set_stats = nullptr);

// Bayesian fusion by FusionRule::kMixture: with w_u = weights[u] (sets of weight 0 are left
// out) and, per group g of sets (SetDistances::group), mu_g and sigma_g the mean and
// standard deviation of all the group's distances together (`set_stats` holds every set's
// ComputeDistanceStats; they are pooled from it),
//   log P(X = i | D) = log P(X = i) + sum_g log( sum_{u in g} w_u L_u(i) / sum_{u in g} w_u )
// + const, where L_u(i) is set u's likelihood (PlaceMatchLogLikelihood with mu_g, sigma_g,
// scaled to mean 1 over the places u covers, and 1 at places it does not cover). Fills `out`
// as FuseBayes does.
void FuseMixture(const std::vector<SetDistances>& sets, const std::vector<double>& weights,
                 int num_places, const LikelihoodOptions& likelihood,
                 const Eigen::VectorXd* log_prior, PlaceBelief* out,
                 const std::vector<DistanceStats>& set_stats);

// Minimum ensemble distance over the sets `use`: the place with the smallest mean distance
// over the used sets that cover it (with full coverage exactly Eq. MED: argmin of the sum).
// Places no used set covers cannot be matched. Fills cost (the mean distance per place,
// +infinity where no used set covers it), match and confidence (minus its mean distance);
// throws std::invalid_argument when no place is covered.
void FuseMinEnsembleDistance(const std::vector<SetDistances>& sets, const std::vector<int>& use,
                             int num_places, PlaceBelief* out);

}  // namespace bsf_vpr
