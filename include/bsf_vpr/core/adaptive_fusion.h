// The default fusion of bsf (FusionRule::kAdaptive): Bayesian model averaging, over the
// stream of queries, of the ways the sets of one descriptor group can relate to the query
// (each set alone, their mixture, their product, and a joint representation of them when
// the map has one). Each hypothesis keeps its own belief filtered along the route and is
// weighted by how well it predicted the queries so far (forgetting over
// fusion_memory_queries); nothing is fitted. With place_means, each place's distances are
// first corrected by how near that place has been to the queries so far (hubs). The
// equations and constants: docs/method.md, "Fusion that adapts" and "Places near every
// query (hubs)".
//
// Not thread-safe: one instance per stream of queries (MethodRunner holds it).
#pragma once

#include <Eigen/Core>
#include <deque>
#include <optional>
#include <vector>

#include "bsf_vpr/core/fusion.h"
#include "bsf_vpr/core/temporal_filter.h"

namespace bsf_vpr {

// How AdaptiveFusion scores its hypotheses and keeps the places' means (MethodOptions::adaptive).
struct AdaptiveFusionOptions {
  // The queries over which a hypothesis's predictions count: lambda = 1 - 1 / memory.
  double memory_queries = 10;
  // Each place's distances corrected by its mean distance to the queries counted so far
  // (above), and the queries n0 after which that mean counts half.
  bool place_means = true;
  double place_prior_queries = 20;
};

class AdaptiveFusion {
 public:
  // One query's inputs, what the selection made of them included. The fusion reads them
  // during Fuse only; the caller owns them.
  struct Query {
    // The query's distances to each set present (`sets`), each set's ComputeDistanceStats
    // (the selection's: one per set) and the condition weights (ConditionWeights, the soft
    // form of the selection rule; one per set, in [0, 1]) over `num_places` places.
    Query(const std::vector<SetDistances>& sets, const std::vector<DistanceStats>& set_stats,
          const std::vector<double>& weights, int num_places)
        : sets(sets), set_stats(set_stats), weights(weights), num_places(num_places) {}

    const std::vector<SetDistances>& sets;
    const std::vector<DistanceStats>& set_stats;
    const std::vector<double>& weights;
    int num_places;
    // Names each set stably across queries (its index in the map, when some sets are
    // missing for this query); null: 0, 1, ...
    const std::vector<int>* set_ids = nullptr;
    // The query's distances to a joint representation of the sets of its group (to every
    // place in order); null: none.
    const SetDistances* joint = nullptr;
    const Eigen::VectorXd* log_prior = nullptr;  // N entries, may be unnormalised; null: uniform
    // The progress since the previous query (odometry: it moves every hypothesis's belief,
    // as +filter's); nullopt: the filter's mean step.
    std::optional<double> step_places;
    LikelihoodOptions likelihood;   // each source's likelihood, as FuseBayes computes it
    TemporalFilterOptions filter;   // how each hypothesis's belief moves between queries
  };

  // Fuses one query as described above and fills `out` as FuseBayes does (the posterior and
  // its best place, for the decision), plus set_weights:
  // per set, the weight its likelihood has, a_u + a_mixture w_u / W + a_product c_u. A set
  // missing from a query has no hypothesis in it, and when it is back its hypothesis starts
  // again (uniform belief, the mean score). Without update_state, or if it throws, the
  // state is left as it was. A query's `joint` adds the hypothesis
  //
  //   joint      the query is best told by what the sets share:                 L_J(i)
  //
  // L_J the training-free likelihood of those distances with their own statistics (their
  // places' means corrected as a set's); PlaceBelief::joint_weight is its a_J. A group with
  // fewer than two sets present leaves it out. Throws std::invalid_argument for inputs
  // that do not fit together or options out of range.
  void Fuse(const Query& query, const AdaptiveFusionOptions& options, bool update_state,
            PlaceBelief* out);

  // Forgets every hypothesis's belief and score, and the places' means.
  void Reset();

  // A query counts towards the places' means only if its distances correlate below this with
  // those of the last query counted (the same scene again: a robot standing still).
  static constexpr double kSameScene = 0.99;
  // A query counted enters the places' means only after this many later queries are
  // counted: the places it nearly matched, just behind the robot, would otherwise look
  // nearer than the place the robot is reaching, and pull the match ahead of it.
  static constexpr int kPlaceMeansLag = 10;

  // The last fused query's hypothesis weights a_h of group `group` (empty if none):
  // the singles in the order of set_ids, then the mixture, the product and the joint.
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

  // Per set id: its places' mean distances over the queries in the mean, and the distances of
  // the counted queries not yet in it (the last of them for the same-scene rule).
  struct PlaceMeans {
    int set_id = -1;
    int queries = 0;                   // in the mean
    Eigen::ArrayXd mean;
    // What is subtracted from each place's distance: n / (n + n0) (mean - its mean over the
    // places), made when the mean or n0 changes.
    double prior_queries = 0;           // the n0 it was made with
    Eigen::ArrayXf correction;
    std::deque<Eigen::ArrayXf> recent;  // counted, not yet in the mean; the last counted last
  };
  // A query's update of one set's place means, made once the query is decided.
  struct PlaceUpdate {
    size_t set = 0;   // index into the query's sets
    int record = -1;  // index into place_means_; -1: a new record
    int set_id = -1;
  };
  // `sets` with the distances of each set that has place means corrected by them (stored in
  // corrected_values_) and their mean and deviation in `corrected_stats` (which holds the
  // raw ones on entry), and the updates this query would make.
  void CorrectByPlaceMeans(const std::vector<SetDistances>& sets, const std::vector<int>* set_ids,
                           int num_places, const AdaptiveFusionOptions& options,
                           std::vector<SetDistances>* corrected,
                           std::vector<DistanceStats>* corrected_stats,
                           std::vector<PlaceUpdate>* updates);
  // A query's sources of evidence: its sets, then (given a joint) the joint representation,
  // with the distances corrected by their places' means (the raw ones where there are none
  // yet) and their statistics, and the updates of the means the query would make.
  struct Sources {
    std::vector<SetDistances> raw, corrected;
    std::vector<DistanceStats> stats;  // of `corrected`
    // The sets' entries of `corrected` and `stats` (all but the joint's).
    std::vector<SetDistances> sets;
    std::vector<DistanceStats> set_stats;
    std::vector<PlaceUpdate> updates;
  };
  // A group's hypotheses' records from the last query.
  struct Records {
    std::vector<const Hypothesis*> of;  // per hypothesis of the query; null: none (new, stale)
    double mean_score = 0;              // over the records kept (0 without)
  };

  // The steps of Fuse (adaptive_fusion.cpp).
  static void CheckQuery(const Query& query, const AdaptiveFusionOptions& options);
  Sources CorrectedSources(const Query& query, const AdaptiveFusionOptions& options);
  // Adds the group's averaged likelihood to out->log_posterior and its sets' weights to
  // out->set_weights; returns what the group would leave in the state.
  GroupState FuseGroup(const Query& query, const Sources& sources, int group,
                       const std::vector<int>& members, const std::vector<int>& components,
                       const AdaptiveFusionOptions& options, PlaceBelief* out);
  GroupState StartHypotheses(int group, const std::vector<int>& set_ids, bool with_joint);
  Records RecordsOf(const GroupState& next, int num_places) const;
  std::vector<const Eigen::ArrayXd*> HypothesisLikelihoods(
      const std::vector<int>& members, const std::vector<double>& mixture_weight,
      const std::vector<double>& exponent, std::optional<size_t> joint, int num_places);
  static void ScoreHypotheses(const Records& records,
                              const std::vector<const Eigen::ArrayXd*>& likelihoods,
                              const AdaptiveFusionOptions& options,
                              const TemporalFilterOptions& filter,
                              std::optional<double> step_places, int num_places, GroupState* next);
  static std::vector<double> AverageHypotheses(
      const GroupState& next, const std::vector<const Eigen::ArrayXd*>& likelihoods, int num_places,
      PlaceBelief* out);
  void Commit(int num_places, const Sources& sources, double prior_queries,
              std::vector<GroupState>* pending);

  // Makes the updates with the raw distances `sets` (after a query that is kept).
  void CountPlaceMeans(const std::vector<SetDistances>& sets,
                       const std::vector<PlaceUpdate>& updates, double prior_queries);
  // n / (n + n0) (mean - its mean over the places), rounded to float.
  static Eigen::ArrayXf Correction(const PlaceMeans& m, double prior_queries);

  int num_places_ = -1;
  std::vector<GroupState> groups_;
  std::vector<PlaceMeans> place_means_;
  std::vector<std::vector<float>> corrected_values_;  // the corrected distances' storage
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
