// The place recogniser of one process, synchronous: a LocalMap (the sets, their distances
// to a query, the joint representation) and a PlaceDecider (the decision, with what it
// carries between queries), the parts the fusion node holds (docs/architecture.md, "One
// query"). Every change is in force at the next query: the query asks the map for the joint
// representation the method needs and waits for what the map builds in the background
// (it, and the first stage's index), so that it is built once after a change, as needed.
// bsf_benchmark and the tests use it.
//
// Not thread-safe: callers serialise access.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/place_decider.h"
#include "bsf_vpr/core/recognizer_options.h"
#include "bsf_vpr/map/local_map.h"

namespace bsf_vpr {

class PlaceRecognizer {
 public:
  // `options.metric` and `options.first_stage` are the map's, fixed here; `storage` is the
  // precision the sets are stored at. Throws std::invalid_argument for invalid options.
  explicit PlaceRecognizer(RecognizerOptions options = {},
                           StoragePrecision storage = StoragePrecision::kFloat32);

  // Replaces the method and its options. Throws std::invalid_argument (and keeps the old
  // options) if they are invalid, the method names a set that is not loaded, or the metric
  // or the first stage differ from the map's. The state carried between queries is kept
  // unless what it depends on changes (PlaceDecider::SetMethod).
  void SetOptions(const RecognizerOptions& options);
  const RecognizerOptions& options() const { return options_; }
  const Method& method() const { return decider_.method(); }

  // Adds a set (see ReferenceSets::Add; throws, the sets unchanged). Resets the carried state.
  void AddReferenceSet(ReferenceSet set);
  // Removes a set. Throws std::invalid_argument if it is not loaded or the current method
  // needs it (nn:<set>, bayes:<set>, with any suffix). Resets the carried state.
  void RemoveReferenceSet(const std::string& name);
  int num_sets() const { return map_->num_sets(); }
  MapBackend::Layout layout() const { return map_->layout(); }
  // Calls `read` with the sets (a benchmark's baselines read the same rows).
  void ReadSets(const std::function<void(const ReferenceSets& sets)>& read) const {
    map_->ReadSets(read);
  }
  // The first stage's index of the sets now (first_stage pca; null for exact search).
  std::shared_ptr<const ApproximateIndex> index();

  // Recognises the place of one descriptor (D floats): the map's query (LocalMap::Ask), then
  // Decide, with the map's own acceptance rule where options().calibration asks for one. With
  // update_state, the state carried between queries (prior, filter, sequence) is updated; without,
  // the recogniser is left exactly as it was (a what-if query). `step_places` is the progress since
  // the previous query from odometry, for +filter methods (nullopt: the filter's step
  // distribution). Throws std::invalid_argument for a descriptor of the wrong dimension, with
  // NaN/inf, or when no set is loaded.
  Recognition Recognize(const Eigen::Ref<const Eigen::VectorXf>& descriptor, bool update_state,
                        std::optional<double> step_places = std::nullopt);
  // The query's distances to every set and to the joint representation the method needs,
  // as Recognize decides from them (a shard of a sharded map publishes the sets' part).
  QueryDistances Distances(const Eigen::Ref<const Eigen::VectorXf>& descriptor);
  // The same decision from distances computed elsewhere (PlaceDecider::Decide on layout():
  // an absent set is left out).
  Recognition Decide(const QueryDistances& distances, bool update_state,
                     std::optional<double> step_places = std::nullopt);

  // Forgets everything carried between queries.
  void ResetPrior() { decider_.Reset(); }
  const PlaceDecider& decider() const { return decider_; }

 private:
  // Asks for the joint the method needs and, where max_false_accept_rate asks for it, the
  // map's calibration; waits for the map's builds.
  void Ready();

  RecognizerOptions options_;
  std::unique_ptr<LocalMap> map_;  // movable with it
  PlaceDecider decider_;
  bool calibrated_ = false;  // the map calibrated for options_ and the sets now
};

}  // namespace bsf_vpr
