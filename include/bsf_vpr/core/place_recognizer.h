// The online place recogniser: M reference sets in memory, one method, and optionally a prior
// carried from one query to the next. This is what the fusion node wraps.
//
// Not thread-safe: callers serialise access (the fusion node holds a mutex).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

struct RecognizerOptions {
  std::string method = "bsf";  // a method name, see methods.h (with +filter / +seq)
  DistanceMetric metric = DistanceMetric::kEuclidean;
  MethodOptions method_options;
  // Carry the belief from query to query: the prior of query t is
  // (1 - prior_uniform_fraction) * P(X | query t-1) + prior_uniform_fraction / N.
  // Off reproduces the paper's single-image setting (uniform prior). A +filter method uses
  // the temporal filter instead (method_options.filter).
  bool carry_prior = false;
  double prior_uniform_fraction = 0.1;  // in (0, 1]; keeps every place reachable

  void Validate() const;  // throws std::invalid_argument naming the bad field
};

struct Recognition {
  PlaceBelief belief;
  // Among the sets the method used, the one whose descriptor of the matched place is closest
  // to the query (-1 if none of them covers the match).
  int closest_set = -1;
};

class PlaceRecognizer {
 public:
  explicit PlaceRecognizer(RecognizerOptions options = {});

  // Replaces the options. Throws std::invalid_argument (and keeps the old options) if they are
  // invalid or the method names a set that is not loaded. Resets the carried prior.
  void SetOptions(const RecognizerOptions& options);
  const RecognizerOptions& options() const { return options_; }
  const Method& method() const { return method_; }

  // Precision at which sets added from now on are stored (ReferenceMap::SetStoragePrecision).
  void SetStoragePrecision(StoragePrecision precision) { map_.SetStoragePrecision(precision); }

  // Adds a set (see ReferenceMap::Add; throws, map unchanged). Resets the carried prior.
  void AddReferenceSet(ReferenceSet set);
  // Removes a set. Throws std::invalid_argument if it is not loaded or the current method
  // needs it (nn:<set>, bayes:<set>). Resets the carried prior.
  void RemoveReferenceSet(const std::string& name);
  const ReferenceMap& map() const { return map_; }

  // Recognises the place of one descriptor (D floats). With update_state, the state carried
  // between queries (prior, filter, sequence) is updated; without, the recogniser is left
  // exactly as it was (a what-if query). `step_places` is the progress since the previous
  // query from odometry, for +filter methods (nullopt: the filter's step distribution).
  // Throws std::invalid_argument for a descriptor of the wrong dimension, with NaN/inf, or
  // when no set is loaded.
  Recognition Recognize(const Eigen::Ref<const Eigen::VectorXf>& descriptor, bool update_state,
                        std::optional<double> step_places = std::nullopt);

  // Forgets everything carried between queries.
  void ResetPrior();

 private:
  MethodRunner& Runner();  // built on demand against the current sets

  RecognizerOptions options_;
  Method method_;
  ReferenceMap map_;
  std::unique_ptr<MethodRunner> runner_;  // null: to be rebuilt
  Eigen::VectorXd carried_log_prior_;     // empty: uniform
};

}  // namespace bsf_vpr
