// The default fusion of bsf (FusionRule::kAdaptive; docs/method.md, "Fusion that adapts"):
// Bayesian model averaging, over the stream of queries, of the ways the sets of one
// descriptor can relate to the query.
//
// Within a descriptor group of sets u = 1..M, each hypothesis h says how the query's
// distances D depend on its place i, as a likelihood L_h(i) of mean 1 over the places:
//
//   single u   the query shows set u's condition; the others tell nothing:  L_u(i)
//   mixture    it shows one of them, which is uncertain (FuseMixture):      sum_u w_u L_u(i) / W
//   product    every set is independent evidence:                           prod_u L_u(i) / mean
//
// with L_u the training-free likelihood with the group's pooled non-match statistics and w_u
// the condition weights (ConditionWeights). Which hypothesis holds is not told by one query:
// each is scored by how well it predicted the queries so far. Hypothesis h carries its own
// belief over places, filtered along the route like +filter (TemporalFilterOptions, or the
// odometry step), and its predictive likelihood of query t is
//
//   p_h(t) = sum_i P_h(X_t = i | D_1..D_{t-1}) L_h(i; D_t),
//
// which is 1 for a hypothesis that tells nothing, above 1 where it put its mass on places the
// route reaches, and far below 1 for a confident hypothesis that is wrong. With forgetting
// lambda = 1 - 1 / fusion_memory_queries, s_h(t) = lambda s_h(t - 1) + log p_h(t), and
//
//   P(X_t = i | D_t)  proportional to  P(X_t = i) prod_g sum_h a_h L_h(i),  a_h = softmax_h s_h(t).
//
// Nothing is fitted: every hypothesis starts equal, and a stream without order (queries
// that do not follow a route) leaves the scores near 0 and the hypotheses near equal.
// Groups of one set need no state: the three hypotheses coincide.
//
// Not thread-safe: one instance per stream of queries (MethodRunner holds it).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "bsf_vpr/core/fusion.h"
#include "bsf_vpr/core/temporal_filter.h"

namespace bsf_vpr {

struct AdaptiveFusionOptions {
  // The queries over which a hypothesis's predictions count: lambda = 1 - 1 / memory.
  double memory_queries = 10;
  TemporalFilterOptions filter;  // how each hypothesis's belief moves between queries
};

class AdaptiveFusion {
 public:
  // Fuses one query as described above and fills `out` as FuseBayes does, plus set_weights:
  // per set, the weight its likelihood has, a_u + a_mixture w_u / W + a_product c_u.
  // `set_ids` (null: 0, 1, ...) names each set of `sets` stably across queries (its index in
  // the map, when some sets are missing for this query); a set missing from a query has no
  // hypothesis in it, and when it is back its hypothesis starts again (uniform belief, the
  // mean score). `step_places` is the progress since the previous query (odometry: it moves
  // every hypothesis's belief, as +filter's), else the filter's mean step. Without
  // update_state, or if it throws, the state is left as it was. `weights` and `set_stats` as
  // for FuseMixture.
  void Fuse(const std::vector<SetDistances>& sets, const std::vector<int>* set_ids,
            const std::vector<double>& weights, int num_places, const LikelihoodOptions& likelihood,
            const Eigen::VectorXd* log_prior, const Threshold& threshold, int top_k,
            const AdaptiveFusionOptions& options, std::optional<double> step_places,
            bool update_state, PlaceBelief* out, const std::vector<DistanceStats>& set_stats);

  // Forgets every hypothesis's belief and score.
  void Reset();

  // The last fused query's hypothesis weights a_h of group `group` (empty if none):
  // the singles in the order of set_ids, then the mixture and the product.
  std::vector<double> LastWeights(int group) const;

 private:
  struct Hypothesis {
    int set_id = -1;            // singles: the set; -1 mixture, -2 product
    Eigen::VectorXd posterior;  // its belief after its last query, up to a factor; empty: none
    double score = 0;
    bool stale = false;  // its set was missing from the last query: back, it starts again
  };
  struct GroupState {
    int group = 0;
    std::vector<Hypothesis> hypotheses;
    std::vector<double> last_weights;
  };
  // Keeps the beliefs' buffers of `hypotheses` in spare_ (up to a bound) and clears it.
  void Recycle(std::vector<Hypothesis>* hypotheses);

  int num_places_ = -1;
  std::vector<GroupState> groups_;
  // Arrays a map's size, kept from query to query so that a query over sets that cover each
  // place once allocates no array of the map's size: the sets' likelihoods (log and linear),
  // a group's mixture and product, and the beliefs of replaced hypotheses, written over by
  // the next query's. Reset() releases them.
  std::vector<Eigen::VectorXd> log_l_;
  std::vector<Eigen::ArrayXd> lin_l_;
  Eigen::ArrayXd mixture_, product_;
  std::vector<Eigen::VectorXd> spare_;
};

}  // namespace bsf_vpr
