// The online place recogniser of one process: M reference sets in memory (ReferenceSets),
// their distances to a query (DistanceStage) and the decision (PlaceDecider), which may
// carry state from one query to the next (+filter: the previous posterior; +seq: the last L
// cost vectors). bsf_benchmark and the tests use it; the fusion node holds the same parts
// behind its map backend (LocalMap or ShardedMap) and bsf_evaluate runs the same
// MethodRunner on its blocks of distances (docs/architecture.md, "One query").
//
// Not thread-safe: callers serialise access (the fusion node holds a mutex).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/place_decider.h"
#include "bsf_vpr/core/query_distances.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

struct RecognizerOptions {
  std::string method = "bsf";  // a method name, see methods.h (with +filter / +seq)
  DistanceMetric metric = DistanceMetric::kEuclidean;
  // The belief is carried between queries by the +filter suffix (method_options.filter);
  // without it every query has a uniform prior, the paper's single-image setting.
  MethodOptions method_options;
  // Exact distances, or the compressed first stage for large maps (first_stage.h).
  FirstStageOptions first_stage;

  void Validate() const;  // throws std::invalid_argument naming the bad field
};

// The options of RecognizerOptions: method and the MethodOptionsTable() (the metric is the
// loaded sets' own, chosen by whoever loads them).
const OptionTable<RecognizerOptions>& RecognizerOptionsTable();

class PlaceRecognizer {
 public:
  explicit PlaceRecognizer(RecognizerOptions options = {});

  // Replaces the options. Throws std::invalid_argument (and keeps the old options) if they are
  // invalid or the method names a set that is not loaded. The state carried between queries
  // is kept unless what it depends on changes: the method or the distance (all of it), the
  // sequence options (the sequence history). Threshold, selection, likelihood, top_k and
  // the filter's step options apply from the next query on.
  void SetOptions(const RecognizerOptions& options);
  const RecognizerOptions& options() const { return options_; }
  const Method& method() const { return decider_.method(); }

  // Precision at which sets added from now on are stored (ReferenceSets::SetStoragePrecision).
  void SetStoragePrecision(StoragePrecision precision) { map_.SetStoragePrecision(precision); }
  // Largest disagreement on a place's pose between sets (ReferenceSets::SetPlacePoseTolerance).
  void SetPlacePoseTolerance(double metres) { map_.SetPlacePoseTolerance(metres); }

  // Adds a set (see ReferenceSets::Add; throws, map unchanged). Resets the carried state.
  void AddReferenceSet(ReferenceSet set);
  // Removes a set. Throws std::invalid_argument if it is not loaded or the current method
  // needs it (nn:<set>, bayes:<set>, with any suffix). Resets the carried state.
  void RemoveReferenceSet(const std::string& name);
  // Throws what RemoveReferenceSet would, without removing anything (a sharded map checks
  // before it asks the shard that holds the set).
  void CheckRemovable(const std::string& name) const;
  const ReferenceSets& map() const { return map_; }

  // Recognises the place of one descriptor (D floats). With update_state, the state carried
  // between queries (prior, filter, sequence) is updated; without, the recogniser is left
  // exactly as it was (a what-if query). `step_places` is the progress since the previous
  // query from odometry, for +filter methods (nullopt: the filter's step distribution).
  // Throws std::invalid_argument for a descriptor of the wrong dimension, with NaN/inf, or
  // when no set is loaded.
  Recognition Recognize(const Eigen::Ref<const Eigen::VectorXf>& descriptor, bool update_state,
                        std::optional<double> step_places = std::nullopt);

  // The same from the query's distances to the sets of map(), computed elsewhere
  // (PlaceDecider::Decide on map().layout(): an absent set is left out). A process that
  // holds some of the sets (a shard of a sharded map) computes them for its sets alone:
  // ComputeDistances gives each set's distances in the same bits whatever other sets share
  // its map, so the decision is bitwise Recognize's.
  Recognition Decide(const QueryDistances& distances, bool update_state,
                     std::optional<double> step_places = std::nullopt);

  // The query's distances to every set of map() (1 x N_u each), as Recognize decides from
  // them: what a shard of a sharded map publishes. Throws std::invalid_argument as
  // Recognize does for the descriptor.
  std::vector<RowMatrixXf> Distances(const Eigen::Ref<const Eigen::VectorXf>& descriptor);

  // The query's distances to the joint representation of the sets the method needs
  // (Method::JointNeeded), built here when first needed after a change of sets (nullopt
  // when the method needs none or the sets make none). Throws as Distances.
  std::optional<QueryDistances::Joint> JointDistances(
      const Eigen::Ref<const Eigen::VectorXf>& descriptor);

  // Forgets everything carried between queries.
  void ResetPrior();

  // Builds what the first stage needs for the current map now (first_stage pca: the
  // index, seconds for a large map) rather than at the next query.
  void PrepareFirstStage() { distances_.Prepare(map_); }
  const DistanceStage& distance_stage() const { return distances_; }
  const PlaceDecider& decider() const { return decider_; }

 private:
  RecognizerOptions options_;
  ReferenceSets map_;
  DistanceStage distances_;
  PlaceDecider decider_;
  uint64_t generation_ = 0;  // changes of sets
  // The joint representation, built for generation joint_generation_ with joint_options_.
  std::shared_ptr<const JointRepresentation> joint_;
  JointOptions joint_options_;
  uint64_t joint_generation_ = 0;
  uint64_t joint_builds_ = 0;
};

}  // namespace bsf_vpr
