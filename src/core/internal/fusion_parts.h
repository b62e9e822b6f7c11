// The parts the fusion rules share (fusion.cpp defines them; adaptive_fusion.cpp uses them
// too): the prior, the sets' likelihoods laid out over places, the decision, and the
// descriptor groups with their pooled non-match statistics.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "bsf_vpr/core/fusion.h"

namespace bsf_vpr {
namespace internal {

// Pearson's correlation of x and y over the entries where both are finite; 0 where it is
// undefined (fewer than two such entries, or no spread).
// Taken by reference: a vector's .array() is read in place, not copied.
double Correlation(const Eigen::Ref<const Eigen::ArrayXd>& x,
                   const Eigen::Ref<const Eigen::ArrayXd>& y);

// The place of d.values[k], checked against the map's place index: throws
// std::invalid_argument naming an id outside 0..num_places - 1.
int CheckedPlace(const SetDistances& d, int k, int num_places);

// Whether value k of d is the distance to place k for every one of num_places places (no
// ids, or ids 0, 1, ...).
bool CoversEachPlaceInOrder(const SetDistances& d, int num_places);

// Starts out->log_posterior from the prior (null: uniform), validated.
void StartFromPrior(const Eigen::VectorXd* log_prior, int num_places, PlaceBelief* out);

// Adds log-likelihood values (one per value of d) at their places.
void AddAtPlaces(const SetDistances& d, const std::vector<double>& values, int num_places,
                 Eigen::VectorXd* to);

// Normalises the log posterior in out->log_posterior and sets the cost, with the posterior's
// best place and its log-odds (from the unnormalised values) in match and confidence, for
// the decision (decision.h).
void NormalizePosterior(PlaceBelief* out);

// The descriptor groups of `sets` (SetDistances::group), in order of first appearance:
// per group all its sets (`members`, for the pooled statistics) and those of non-zero
// weight (`components`, the sets a rule may fuse). Throws std::invalid_argument for a
// weight outside [0, 1] or a size mismatch.
struct Groups {
  std::vector<int> ids;
  std::vector<std::vector<int>> members, components;
};
Groups GroupSets(const std::vector<SetDistances>& sets, const std::vector<double>& weights);

// Per set of some group's components: the group's pooled non-match statistics (the mean and
// deviation of all the group's distances together); entries of other sets are default.
std::vector<DistanceStats> PooledGroupStats(const std::vector<SetDistances>& sets,
                                            const Groups& groups,
                                            const std::vector<DistanceStats>& set_stats);

// Per set u of some group's components: L_u(i) as FuseMixture defines it (the training-free
// likelihood with the group's pooled statistics, mean 1 over the places u covers), laid out
// over the places (log, 0 where u does not cover). Entry u is empty for the other sets.
std::vector<Eigen::VectorXd> PooledLogLikelihoods(const std::vector<SetDistances>& sets,
                                                  const Groups& groups, int num_places,
                                                  const LikelihoodOptions& likelihood,
                                                  const std::vector<DistanceStats>& set_stats);

// log sum_j (w_j / W) exp(l_j(i)) per place over the columns `l_j` = columns[u] of the sets
// `members` with weights w (W their sum): the mixture of the sets' likelihoods.
Eigen::ArrayXd LogMixture(const std::vector<Eigen::VectorXd>& columns,
                          const std::vector<int>& members, const std::vector<double>& weights);

}  // namespace internal
}  // namespace bsf_vpr
