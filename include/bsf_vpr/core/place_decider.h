// The decision of the online recogniser: one method (bsf, bayes_full, ... with +filter and
// +seq, methods.h) run query after query on a place layout and each query's distances,
// carrying its state from one query to the next (+filter: the previous posterior; +seq: the
// last L cost vectors). It holds no descriptors: the distances come from whoever holds them
// (a LocalMap, in the node or in PlaceRecognizer; the shards of a sharded map). The same distances
// give the same bits wherever they were computed.
//
// Not thread-safe: callers serialise access.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/query_distances.h"

namespace bsf_vpr {

struct Recognition {
  PlaceBelief belief;
  // Among the sets the method used, the one whose descriptor of the matched place is closest
  // to the query (-1 if none of them covers the match).
  int closest_set = -1;
  // The sets whose distances were absent (QueryDistances; a shard that did not answer),
  // ascending: the belief was decided without them.
  std::vector<int> missing_sets;
};

class PlaceDecider {
 public:
  // The method by name and its options (validated: throws std::invalid_argument), resolved
  // against a layout at OnLayoutChanged.
  explicit PlaceDecider(std::string method = "bsf", MethodOptions options = {});

  // Sets the method (by name, see methods.h) and its options, resolved against `layout`'s
  // sets. Throws std::invalid_argument (and keeps what it had) if the options are invalid or
  // the method names a set the layout lacks. The carried state is kept unless the method
  // changes (then it starts afresh) or the sequence options do (the sequence history).
  void SetMethod(const std::string& method, const MethodOptions& options,
                 const PlaceLayout& layout);
  const std::string& method_name() const { return method_name_; }
  const MethodOptions& method_options() const { return options_; }
  // The method as resolved against the layout last given.
  const Method& method() const { return method_; }
  // Why the method could not be resolved against the layout last given ("" if it was).
  const std::string& problem() const { return unresolved_; }

  // The layout's sets changed (added, removed, reordered): the method is resolved against
  // them again and the carried state starts afresh. Never throws: a method naming a set
  // that is gone is reported by the next Decide (and by SetMethod).
  void OnLayoutChanged(const PlaceLayout& layout);
  // Throws std::invalid_argument when the method needs the named set (nn:<set>, bayes:<set>),
  // so it must not be removed.
  void CheckRemovable(const std::string& name) const;
  // Forgets what is carried between queries.
  void Reset();
  // The map's acceptance rule (MapBackend::Query::acceptance_rule; nullopt: the threshold
  // alone) for the queries from now on; the carried state is kept.
  void SetAcceptanceRule(std::optional<AcceptanceRule> rule);

  // Decides one query from its distances to `layout`'s sets. With update_state, the carried
  // state is updated; without, the decider is left exactly as it was (a what-if query).
  // `step_places` is the progress since the previous query from odometry, for +filter
  // methods (nullopt: the filter's step distribution). An absent set is left out: the
  // method runs on the others (MethodRunner::Step's `available`) and
  // Recognition::missing_sets names it. Throws std::invalid_argument, the state untouched,
  // when the layout is empty, the distances do not fit it (number of sets, 1 x N_u each), a
  // value is negative, NaN or infinite, every set is absent, the method is nn:/bayes: of an
  // absent set, or it names a set the layout lacks. The distances' joint representation
  // (QueryDistances::joint), if any, goes to the method (bsf's joint hypothesis, the
  // descriptor-level methods); when its build changes, the carried state starts again.
  Recognition Decide(const PlaceLayout& layout, const QueryDistances& distances, bool update_state,
                     std::optional<double> step_places = std::nullopt);

 private:
  std::string method_name_;
  MethodOptions options_;
  Method method_;                                   // method_name_ resolved against the last layout
  std::string unresolved_ = "no layout given yet";  // why method_ is not resolved ("" if it is)
  std::unique_ptr<MethodRunner> runner_;            // null: built at the next Decide
  uint64_t joint_build_ = 0;  // the joint representation's build runner_ has seen (0: none)
  std::optional<AcceptanceRule> rule_;
};

}  // namespace bsf_vpr
