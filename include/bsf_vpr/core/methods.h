// Every place recognition method the paper compares, selectable by name:
//
//   nn:<set>       single-reference nearest neighbour (minimum-value principle, Eq. mvp)
//   bayes:<set>    single-reference Bayesian (training-free likelihood, uniform/given prior)
//   med            Baseline Fusion: minimum ensemble distance over all sets (Eq. MED)
//   med_selective  Baseline Selective Fusion: MED over the selected sets S
//   bayes_full     Bayesian Full Fusion: Bayes over all sets
//   bsf            Bayesian Selective Fusion: Bayes over the selected sets S (by default
//                  with what the sets share as one more source: fusion_joint)
//
// and the multi-reference methods of the field that fuse the sets at the descriptor level,
// each Bayes (the training-free likelihood) on one source built from all the sets (sets of
// one descriptor that share places; docs/method.md, "What the references share"):
//   mean_descriptor  the distance to each place's mean descriptor
//   union_nn         each place's smallest distance over the sets (nearest neighbour over
//                    the union of the references)
//   subspace         the residual of the query's projection on each place's subspace
//   discriminant     the distance in the discriminant projection of the references
//
// Suffixes extend a method over time (queries must then arrive in traversal order):
//   +filter        the prior of each query is the temporal filter's prediction from the
//                  previous posterior (Bayesian methods only; temporal_filter.h)
//   +seq           the match is the end of the best sequence of the last L queries
//                  (sequence_matcher.h); e.g. bsf+seq, nn:winter+seq, bsf+filter+seq
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/adaptive_fusion.h"
#include "bsf_vpr/core/decision.h"
#include "bsf_vpr/core/fusion.h"
#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/off_map.h"
#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/sequence_matcher.h"
#include "bsf_vpr/core/temporal_filter.h"

namespace bsf_vpr {

struct MethodOptions;

enum class MethodKind {
  kNearestNeighbour,
  kBayesSingle,
  kMed,
  kMedSelective,
  kBayesFull,
  kBsf,
  kMeanDescriptor,
  kUnionNn,
  kSubspace,
  kDiscriminant
};

// The methods' names, written once: Method::Name, ParseMethod, its message and AllMethods
// come from it, in the order AllMethods lists the methods. nn and bayes run on one set, named
// after a colon (nn:<set>, bayes:<set>).
const EnumNames<MethodKind>& MethodKindNames();

// What bsf (fusion adaptive) adds to the sets' hypotheses: a joint representation of them
// as one more, or nothing (the sets alone).
enum class FusionJoint { kNone, kMeanDescriptor, kSubspace, kDiscriminant };
const EnumNames<FusionJoint>& FusionJointNames();
std::optional<JointKind> ToJointKind(FusionJoint joint);

// One query's distances to a joint representation of the sets (JointRepresentation).
struct JointDistances {
  JointKind kind = JointKind::kDiscriminant;
  SetDistances distances;  // to every place, in order (count = the places)
};

struct Method {
  MethodKind kind = MethodKind::kBsf;
  int set_index = -1;            // for nn:/bayes:, the set's index in the map
  std::string set_name;          // for nn:/bayes:
  bool temporal_filter = false;  // +filter
  bool sequence = false;         // +seq

  std::string Name() const;  // e.g. "bsf", "nn:winter", "bsf+filter+seq"
  bool IsBayesian() const;
  // The joint representation the method needs with `options` (mean_descriptor, subspace,
  // discriminant; bsf with fusion adaptive and fusion_joint), if any.
  std::optional<JointKind> JointNeeded(const MethodOptions& options) const;
  // Whether the method fuses the sets at the descriptor level (the sets must share places).
  bool NeedsSharedPlaces() const;
  // Whether a query's result depends on the queries before it (+filter, +seq, bsf with
  // fusion adaptive, or a Bayesian method with off_map): such a method sees the queries in
  // traversal order, one at a time.
  bool CarriesState(const MethodOptions& options) const;
  std::string BaseName() const;  // without suffixes
};

// Parses one method name against the map's set names. Throws std::invalid_argument for an
// unknown method or set name (the message lists the valid ones).
Method ParseMethod(const std::string& name, const std::vector<std::string>& set_names);
// A comma-separated list of names; the item "all" stands for every method, with nn: and
// bayes: for every set ("all,bsf+filter"). A repeated method is kept once, where it first
// appears.
std::vector<Method> ParseMethodList(const std::string& list,
                                    const std::vector<std::string>& set_names,
                                    bool joint_methods = false);
// Every method of the paper, then the descriptor-level ones (with `joint_methods`: sets of
// one descriptor that share places), then bayes: and nn: of every set.
std::vector<Method> AllMethods(const std::vector<std::string>& set_names,
                               bool joint_methods = false);

struct MethodOptions {
  SelectionOptions selection;
  LikelihoodOptions likelihood;
  FusionRule fusion = FusionRule::kAdaptive;  // how bsf fuses the sets (fusion.h)
  // fusion adaptive: how its hypotheses are scored and the places' means kept
  // (fusion_memory_queries, fusion_place_means, fusion_place_prior_queries)
  AdaptiveFusionOptions adaptive;
  FusionJoint fusion_joint = FusionJoint::kDiscriminant;
  JointOptions joint;  // how the joint representations are built
  // What accepts a match and how many places are ranked (threshold, threshold_kind,
  // max_match_distance, top_k): read by the decision alone (decision.h)
  DecisionOptions decision;
  SequenceOptions sequence;      // for +seq methods
  TemporalFilterOptions filter;  // for +filter methods
  // Bayesian methods: the hypothesis that the query shows no place of the map (off_map.h)
  OffMapOptions off_map;

  void Validate() const;  // throws std::invalid_argument naming the bad field
};

// The options of MethodOptions (options.h): the same names as ROS parameters, as
// command-line flags (--gamma-fraction) and in dynamic_reconfigure.
const OptionTable<MethodOptions>& MethodOptionsTable();

// Runs `method` on one query's distances to every set of the map (`sets[u]` for set u,
// each with count > 0). `log_prior` (N entries, may be unnormalised) or null for uniform;
// only the Bayesian methods use it. The returned belief keeps apart what the selection rule
// chose (selection.selected, computed for every method) and the sets the method fused
// (used_sets). It is not decided: match and confidence are the posterior's (or the mean
// distances') best place, accepted is false and top_places empty until Decide (decision.h),
// which MethodRunner::Step runs.
//
// bsf with fusion adaptive scores its hypotheses over the stream: `stream` carries that
// state (MethodRunner holds it); null runs the query as the first of a stream.
// `joint` holds the query's distances to the joint representations the method needs
// (Method::JointNeeded); a method that needs one not given throws std::invalid_argument,
// except bsf, which then fuses the sets alone. union_nn throws when the sets are of
// different groups or no place is covered by two of them.
struct FusionStream {
  AdaptiveFusion* state = nullptr;
  std::optional<double> step_places;          // odometry, for the hypotheses' filters
  bool update_state = true;                   // false: `state` is left as it was
  const std::vector<int>* set_ids = nullptr;  // each set's index in the map (null: 0, 1, ...)
};
PlaceBelief RunMethod(const Method& method, const std::vector<SetDistances>& sets, int num_places,
                      const MethodOptions& options, const Eigen::VectorXd* log_prior = nullptr,
                      const FusionStream* stream = nullptr,
                      const std::vector<JointDistances>* joint = nullptr);

}  // namespace bsf_vpr
