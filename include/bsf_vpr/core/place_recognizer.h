// The online place recogniser: M reference sets in memory and one method, which may carry
// state from one query to the next (+filter: the previous posterior; +seq: the last L cost
// vectors). This is what the fusion node wraps.
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

struct Recognition {
  PlaceBelief belief;
  // Among the sets the method used, the one whose descriptor of the matched place is closest
  // to the query (-1 if none of them covers the match).
  int closest_set = -1;
  // The sets whose distances were missing (RecognizeDistances: a shard that did not
  // answer), ascending: the belief was decided without them.
  std::vector<int> missing_sets;
};

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
  // The method parsed against the current sets (once per change of the options or the
  // sets). While it names a set that is not loaded, the one parsed before (Recognize throws).
  const Method& method() const { return method_; }

  // Precision at which sets added from now on are stored (ReferenceMap::SetStoragePrecision).
  void SetStoragePrecision(StoragePrecision precision) { map_.SetStoragePrecision(precision); }
  // Largest disagreement on a place's pose between sets (ReferenceMap::SetPlacePoseTolerance).
  void SetPlacePoseTolerance(double metres) { map_.SetPlacePoseTolerance(metres); }

  // Adds a set (see ReferenceMap::Add; throws, map unchanged). Resets the carried state.
  void AddReferenceSet(ReferenceSet set);
  // Removes a set. Throws std::invalid_argument if it is not loaded or the current method
  // needs it (nn:<set>, bayes:<set>, with any suffix). Resets the carried state.
  void RemoveReferenceSet(const std::string& name);
  // Throws what RemoveReferenceSet would, without removing anything (a sharded map checks
  // before it asks the shard that holds the set).
  void CheckRemovable(const std::string& name) const;
  const ReferenceMap& map() const { return map_; }

  // Recognises the place of one descriptor (D floats). With update_state, the state carried
  // between queries (prior, filter, sequence) is updated; without, the recogniser is left
  // exactly as it was (a what-if query). `step_places` is the progress since the previous
  // query from odometry, for +filter methods (nullopt: the filter's step distribution).
  // Throws std::invalid_argument for a descriptor of the wrong dimension, with NaN/inf, or
  // when no set is loaded.
  Recognition Recognize(const Eigen::Ref<const Eigen::VectorXf>& descriptor, bool update_state,
                        std::optional<double> step_places = std::nullopt);

  // The same from the query's distances to every set, computed elsewhere: `distances[u]` is
  // 1 x N_u for set u of map() (in its order), as ComputeDistances gives them. A process that
  // holds some of the sets (a shard of a sharded map) computes them for its sets alone:
  // ComputeDistances gives each set's distances in the same bits whatever other sets share
  // its map, so the recognition is bitwise Recognize's. Throws std::invalid_argument (the
  // state untouched) for the wrong number of sets, a wrong size, or a value that is
  // negative, NaN or infinite.
  //
  // An empty matrix (0 x 0) stands for a set whose distances are missing (its shard did not
  // answer): the method decides on the others (MethodRunner::Step's `available`) and
  // Recognition::missing_sets names it. Throws when every set is missing or the method is
  // nn:/bayes: of a missing one.
  Recognition RecognizeDistances(const std::vector<RowMatrixXf>& distances, bool update_state,
                                 std::optional<double> step_places = std::nullopt);

  // The query's distances to every set of map() (1 x N_u each), as Recognize decides from
  // them: what a shard of a sharded map publishes. Throws std::invalid_argument as
  // Recognize does for the descriptor.
  std::vector<RowMatrixXf> Distances(const Eigen::Ref<const Eigen::VectorXf>& descriptor);

  // Forgets everything carried between queries.
  void ResetPrior();

  // Builds what the first stage needs for the current map now (first_stage pca: the
  // index, seconds for a large map) rather than at the next query.
  void PrepareFirstStage() { distances_.Prepare(map_); }
  const DistanceStage& distance_stage() const { return distances_; }

 private:
  MethodRunner& Runner();  // built on demand against the current sets
  // Parses options_.method against the sets into method_ after the sets changed, or keeps
  // in method_error_ why it cannot be (it names a set not loaded, or no method at all).
  void ResolveMethod();
  // method_, or throws std::invalid_argument with method_error_.
  const Method& ResolvedMethod() const;
  // Fusion, state and the closest set from checked distances (Recognize, RecognizeDistances).
  // `available` null: every set.
  Recognition Decide(const std::vector<RowMatrixXf>& distances, bool update_state,
                     std::optional<double> step_places, const std::vector<bool>* available);

  RecognizerOptions options_;
  Method method_;             // options_.method against map_'s sets, when it resolves
  std::string method_error_;  // why it does not, or ""
  ReferenceMap map_;
  std::unique_ptr<MethodRunner> runner_;  // null: to be rebuilt
  DistanceStage distances_;
};

}  // namespace bsf_vpr
