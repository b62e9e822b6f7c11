#include "bsf_vpr/core/place_recognizer.h"

#include <algorithm>
#include <stdexcept>

namespace bsf_vpr {

void RecognizerOptions::Validate() const {
  method_options.Validate();
  first_stage.Validate();
}

const OptionTable<RecognizerOptions>& RecognizerOptionsTable() {
  static const OptionTable<RecognizerOptions> kTable =
      OptionTable<RecognizerOptions>()
          .Add(
              "method", [](auto& o) -> auto& { return o.method; },
              "bsf, bayes_full, med, med_selective, nn:<set> or bayes:<set>, optionally with "
              "+filter (temporal filter prior) and/or +seq (sequence matching)",
              "", {}, /*live=*/true)
          .Include(
              MethodOptionsTable(), [](auto& o) -> auto& { return o.method_options; })
          .Include(
              FirstStageOptionsTable(), [](auto& o) -> auto& { return o.first_stage; });
  return kTable;
}

PlaceRecognizer::PlaceRecognizer(RecognizerOptions options) : options_(std::move(options)) {
  options_.Validate();
  distances_.SetOptions(options_.first_stage);
  // The method is checked against the sets when they are known (SetOptions / Recognize).
  ResolveMethod();
}

void PlaceRecognizer::SetOptions(const RecognizerOptions& options) {
  options.Validate();
  Method method = ParseMethod(options.method, map_.SetNames());
  const bool restart = options.method != options_.method || options.metric != options_.metric;
  distances_.SetOptions(options.first_stage);
  options_ = options;
  method_ = method;
  method_error_.clear();
  if (restart || !runner_) {
    runner_.reset();  // rebuilt, with no history, at the next query
  } else {
    runner_->SetOptions(options_.method_options);  // keeps what the change leaves valid
  }
}

void PlaceRecognizer::AddReferenceSet(ReferenceSet set) {
  map_.Add(std::move(set));
  distances_.Invalidate();
  runner_.reset();
  ResetPrior();
  ResolveMethod();
}

void PlaceRecognizer::RemoveReferenceSet(const std::string& name) {
  CheckRemovable(name);
  map_.Remove(name);
  distances_.Invalidate();
  runner_.reset();
  ResetPrior();
  ResolveMethod();
}

void PlaceRecognizer::ResolveMethod() {
  try {
    method_ = ParseMethod(options_.method, map_.SetNames());
    method_error_.clear();
  } catch (const std::invalid_argument& e) {
    method_error_ = e.what();  // thrown when the method is needed
  }
}

const Method& PlaceRecognizer::ResolvedMethod() const {
  if (!method_error_.empty()) throw std::invalid_argument(method_error_);
  return method_;
}

void PlaceRecognizer::CheckRemovable(const std::string& name) const {
  if (map_.IndexOf(name) < 0) {
    throw std::invalid_argument("no reference set named '" + name + "' is loaded");
  }
  // The method as parsed (suffixes and all) says which set it needs by name.
  const Method& method = ResolvedMethod();
  const bool single =
      method.kind == MethodKind::kNearestNeighbour || method.kind == MethodKind::kBayesSingle;
  if (single && method.set_name == name) {
    throw std::invalid_argument("reference set '" + name + "' is used by method '" +
                                options_.method + "'; change the method first");
  }
}

void PlaceRecognizer::ResetPrior() {
  if (runner_) runner_->Reset();
}

MethodRunner& PlaceRecognizer::Runner() {
  if (!runner_) runner_ = std::make_unique<MethodRunner>(ResolvedMethod(), options_.method_options);
  return *runner_;
}

Recognition PlaceRecognizer::Recognize(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                                       bool update_state, std::optional<double> step_places) {
  return Decide(Distances(descriptor), update_state, step_places, nullptr);
}

std::vector<RowMatrixXf> PlaceRecognizer::Distances(
    const Eigen::Ref<const Eigen::VectorXf>& descriptor) {
  if (map_.num_sets() == 0) throw std::invalid_argument("no reference set is loaded");
  if (descriptor.size() != map_.dimension()) {
    throw std::invalid_argument("descriptor has dimension " + std::to_string(descriptor.size()) +
                                ", the reference sets have dimension " +
                                std::to_string(map_.dimension()));
  }
  const std::string problem = DescriptorProblem(descriptor.transpose());
  if (!problem.empty()) throw std::invalid_argument("descriptor " + problem);
  const RowMatrixXf query = descriptor.transpose();
  return distances_.Distances(options_.metric, query, map_);
}

Recognition PlaceRecognizer::RecognizeDistances(const std::vector<RowMatrixXf>& distances,
                                                bool update_state,
                                                std::optional<double> step_places) {
  if (map_.num_sets() == 0) throw std::invalid_argument("no reference set is loaded");
  if (static_cast<int>(distances.size()) != map_.num_sets()) {
    throw std::invalid_argument("distances for " + std::to_string(distances.size()) +
                                " set(s), the map holds " + std::to_string(map_.num_sets()));
  }
  std::vector<bool> available(distances.size(), true);
  for (int u = 0; u < map_.num_sets(); ++u) {
    const RowMatrixXf& d = distances[static_cast<size_t>(u)];
    const StoredReferenceSet& set = map_.set(u);
    if (d.size() == 0 && d.rows() == 0) {
      available[static_cast<size_t>(u)] = false;  // missing (a set is never empty)
      continue;
    }
    if (d.rows() != 1 || d.cols() != set.size()) {
      throw std::invalid_argument("distances to set '" + set.name() + "' are " +
                                  std::to_string(d.rows()) + " x " + std::to_string(d.cols()) +
                                  ", expected 1 x " + std::to_string(set.size()));
    }
    // A distance is finite and not negative (NaN compares false): anything else would
    // silently corrupt the belief.
    if (!(d.array() >= 0.0f).all() || !d.allFinite()) {
      throw std::invalid_argument("distances to set '" + set.name() +
                                  "' hold a negative, NaN or infinite value");
    }
  }
  return Decide(distances, update_state, step_places, &available);
}

Recognition PlaceRecognizer::Decide(const std::vector<RowMatrixXf>& distances, bool update_state,
                                    std::optional<double> step_places,
                                    const std::vector<bool>* available) {
  std::vector<SetDistances> views(distances.size());
  for (size_t u = 0; u < distances.size(); ++u) {
    if (available && !(*available)[u]) continue;  // count 0: never read
    views[u].values = distances[u].data();
    views[u].count = static_cast<int>(distances[u].cols());
    views[u].place_ids = map_.set(static_cast<int>(u)).place_ids().data();
  }

  const int n = map_.num_places();
  Recognition out;
  out.belief = Runner().Step(views, n, nullptr, step_places, update_state, available);
  if (available) {
    for (size_t u = 0; u < available->size(); ++u) {
      if (!(*available)[u]) out.missing_sets.push_back(static_cast<int>(u));
    }
  }

  // The set that supplied the match: the closest image of the match among the sets the
  // method relied on (a mixture's used sets of weight below 1 only when also selected).
  const std::vector<int>& selected = out.belief.selection.selected;
  float best = INFINITY;
  for (int u : out.belief.used_sets) {
    if (out.belief.set_weights.at(static_cast<size_t>(u)) < 1 &&
        !std::binary_search(selected.begin(), selected.end(), u)) {
      continue;
    }
    const SetDistances& d = views[static_cast<size_t>(u)];
    for (int k = 0; k < d.count; ++k) {
      if (d.PlaceAt(k) == out.belief.match && d.values[k] < best) {
        best = d.values[k];
        out.closest_set = u;
      }
    }
  }

  return out;
}

}  // namespace bsf_vpr
