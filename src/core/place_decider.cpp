#include "bsf_vpr/core/place_decider.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace bsf_vpr {

PlaceDecider::PlaceDecider(std::string method, MethodOptions options)
    : method_name_(std::move(method)), options_(std::move(options)) {
  options_.Validate();
}

void PlaceDecider::SetMethod(const std::string& method, const MethodOptions& options,
                             const PlaceLayout& layout) {
  options.Validate();
  Method resolved = ParseMethod(method, layout.SetNames());
  const bool restart = method != method_name_;
  method_name_ = method;
  options_ = options;
  method_ = std::move(resolved);
  unresolved_.clear();
  if (restart || !runner_) {
    runner_.reset();  // rebuilt, with no history, at the next query
  } else {
    runner_->SetOptions(options_);  // keeps what the change leaves valid
  }
}

void PlaceDecider::OnLayoutChanged(const PlaceLayout& layout) {
  runner_.reset();
  try {
    method_ = ParseMethod(method_name_, layout.SetNames());  // sets are named by index
    unresolved_.clear();
  } catch (const std::exception& e) {
    unresolved_ = e.what();
  }
}

void PlaceDecider::CheckRemovable(const std::string& name) const {
  const bool single =
      method_.kind == MethodKind::kNearestNeighbour || method_.kind == MethodKind::kBayesSingle;
  if (unresolved_.empty() && single && method_.set_name == name) {
    throw std::invalid_argument("reference set '" + name + "' is used by method '" + method_name_ +
                                "'; change the method first");
  }
}

void PlaceDecider::Reset() { runner_.reset(); }

namespace {

// Each set's distances as a view on its places (count 0 where absent: `available` false),
// checked to fit the layout: 1 x N_u, finite and not negative.
std::vector<SetDistances> SetViews(const PlaceLayout& layout, const QueryDistances& distances,
                                   std::vector<bool>* available) {
  if (layout.num_sets() == 0) throw std::invalid_argument("no reference set is loaded");
  if (distances.num_sets() != layout.num_sets()) {
    throw std::invalid_argument("distances for " + std::to_string(distances.num_sets()) +
                                " set(s), the map holds " + std::to_string(layout.num_sets()));
  }
  available->assign(static_cast<size_t>(layout.num_sets()), true);
  std::vector<SetDistances> views(static_cast<size_t>(layout.num_sets()));
  for (int u = 0; u < layout.num_sets(); ++u) {
    const SetLayout& set = layout.set(u);
    if (!distances.present(u)) {
      (*available)[static_cast<size_t>(u)] = false;  // count 0: never read
      continue;
    }
    const RowMatrixXf& d = distances.of(u);
    if (d.rows() != 1 || d.cols() != set.size()) {
      throw std::invalid_argument("distances to set '" + set.name + "' are " +
                                  std::to_string(d.rows()) + " x " + std::to_string(d.cols()) +
                                  ", expected 1 x " + std::to_string(set.size()));
    }
    // A distance is finite and not negative (NaN compares false): anything else would
    // silently corrupt the belief.
    if (!(d.array() >= 0.0f && d.array() <= std::numeric_limits<float>::max()).all()) {
      throw std::invalid_argument("distances to set '" + set.name +
                                  "' hold a negative, NaN or infinite value");
    }
    SetDistances& view = views[static_cast<size_t>(u)];
    view.values = d.data();
    view.count = static_cast<int>(d.cols());
    view.place_ids = set.place_ids.data();
  }
  return views;
}

// The query's distances to the joint representation, if any, checked to cover every place.
std::vector<JointDistances> JointViews(const PlaceLayout& layout, const QueryDistances& distances) {
  std::vector<JointDistances> joint;
  if (const std::optional<QueryDistances::Joint>& j = distances.joint()) {
    const RowMatrixXf& d = j->distances;
    if (d.rows() != 1 || d.cols() != layout.num_places() ||
        !(d.array() >= 0.0f && d.array() <= std::numeric_limits<float>::max()).all()) {
      throw std::invalid_argument("the " + ToString(j->kind) + " distances are " +
                                  std::to_string(d.rows()) + " x " + std::to_string(d.cols()) +
                                  " (expected 1 x " + std::to_string(layout.num_places()) +
                                  ", finite and not negative)");
    }
    joint.push_back({j->kind, SetDistances{d.data(), nullptr, static_cast<int>(d.cols()), 0}});
  }
  return joint;
}

}  // namespace

void PlaceDecider::SetAcceptanceRule(std::optional<AcceptanceRule> rule) { rule_ = rule; }

Recognition PlaceDecider::Decide(const PlaceLayout& layout, const QueryDistances& distances,
                                 bool update_state, std::optional<double> step_places) {
  std::vector<bool> available;
  const std::vector<SetDistances> views = SetViews(layout, distances, &available);
  std::vector<JointDistances> joint = JointViews(layout, distances);
  if (!unresolved_.empty()) throw std::invalid_argument(unresolved_);
  // A new build of the joint representation: what was carried was scored with another.
  const uint64_t build = distances.joint() ? distances.joint()->build : 0;
  std::unique_ptr<MethodRunner> what_if;
  if (build != joint_build_) {
    if (update_state) {
      runner_.reset();
      joint_build_ = build;
    } else {
      what_if = std::make_unique<MethodRunner>(method_, options_);
    }
  }
  if (!runner_) runner_ = std::make_unique<MethodRunner>(method_, options_);
  MethodRunner& runner = what_if ? *what_if : *runner_;
  runner.SetAcceptanceRule(rule_);

  Recognition out;
  const bool all = distances.num_present() == layout.num_sets();
  out.belief = runner.Step(views, layout.num_places(), nullptr, step_places, update_state,
                           all ? nullptr : &available, &joint);
  out.missing_sets = distances.Absent();
  out.closest_set = out.belief.match_distance_set;  // the decision found it
  return out;
}

}  // namespace bsf_vpr
