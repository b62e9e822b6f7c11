#include "src/ros/fusion/selection_counters.h"

namespace bsf_vpr {
namespace {

long CountOf(const std::map<std::string, long>& m, const std::string& key) {
  const auto it = m.find(key);
  return it == m.end() ? 0L : it->second;
}

}  // namespace

void SelectionCounters::Count(const Recognition& r, const PlaceLayout& layout) {
  ++queries_;
  for (int u : r.belief.selection.selected) ++selected_[layout.set(u).name];
  if (r.belief.selection.best >= 0) ++best_[layout.set(r.belief.selection.best).name];
  if (r.closest_set >= 0) ++supplied_[layout.set(r.closest_set).name];
  for (size_t u = 0; u < r.belief.set_weights.size(); ++u) {
    weight_[layout.set(static_cast<int>(u)).name] += r.belief.set_weights[u];
  }
}

void SelectionCounters::Forget(const std::string& set_name) {
  selected_.erase(set_name);
  best_.erase(set_name);
  supplied_.erase(set_name);
  weight_.erase(set_name);
}

void SelectionCounters::Reset() {
  selected_.clear();
  best_.clear();
  supplied_.clear();
  weight_.clear();
  queries_ = 0;
}

ReferenceSetUsage SelectionCounters::Usage(const std::string& set_name) const {
  ReferenceSetUsage u;
  u.name = set_name;
  u.selected = CountOf(selected_, set_name);
  u.best = CountOf(best_, set_name);
  u.supplied_match = CountOf(supplied_, set_name);
  u.selected_fraction = queries_ ? static_cast<double>(u.selected) / queries_ : 0.0;
  const auto w = weight_.find(set_name);
  u.mean_weight = queries_ && w != weight_.end() ? w->second / queries_ : 0.0;
  return u;
}

}  // namespace bsf_vpr
