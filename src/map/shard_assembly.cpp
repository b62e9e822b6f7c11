#include "bsf_vpr/map/shard_assembly.h"

#include <algorithm>
#include <stdexcept>

#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/shard_join.h"

namespace bsf_vpr {

MergedLayout MergeShardLayouts(const std::vector<const ShardSets*>& shards,
                               const std::string& fallback,
                               std::optional<DistanceMetric> configured, double pose_tolerance_m) {
  std::string distance;
  MergedLayout out;
  PlaceLayout& layout = out.layout;
  layout.SetPlacePoseTolerance(pose_tolerance_m);
  for (const ShardSets* shard : shards) {
    if (!shard || shard->sets.empty()) continue;
    if (distance.empty()) distance = shard->distance;
    if (shard->distance != distance) {
      throw std::invalid_argument("the shards' sets are meant for different distances (" +
                                  distance + ", and " + shard->distance + " on shard " +
                                  shard->name + ")");
    }
    for (const ShardSets::Set& s : shard->sets) {
      const std::string& name = s.layout.name;
      if (const std::string bad = SetNameProblem(name); !bad.empty()) {
        throw std::invalid_argument("shard " + shard->name + " holds a set " + bad);
      }
      if (layout.IndexOf(name) >= 0) {
        throw std::invalid_argument("set '" + name + "' is held by two shards");
      }
      if (layout.dimension() != 0 && s.layout.dimension != layout.dimension()) {
        throw std::invalid_argument("set '" + name + "' has dimension " +
                                    std::to_string(s.layout.dimension) + ", the map " +
                                    std::to_string(layout.dimension()));
      }
      layout.Add(s.layout);
    }
  }
  out.metric = ParseDistanceMetric(distance.empty() ? fallback : distance);
  if (layout.num_sets() > 0 && configured && out.metric != *configured) {
    throw std::invalid_argument("the shards use " + ToString(out.metric) + " distance, this node " +
                                ToString(*configured));
  }
  return out;
}

namespace {

// Whether `answer` holds `shard`'s sets' distances: not for other sets, fingerprints or
// counts (a shard whose new shard_info has not arrived, or was refused), nor a refusal.
bool AnswersItsSets(const ShardAnswer& answer, const ShardSets& shard) {
  const size_t n = shard.sets.size();
  if (!answer.error.empty() || answer.malformed || answer.set_names.size() != n ||
      answer.fingerprints.size() != n || answer.distances.size() != n) {
    return false;
  }
  for (size_t i = 0; i < n; ++i) {
    const ShardSets::Set& s = shard.sets[i];
    if (answer.set_names[i] != s.layout.name || answer.fingerprints[i] != s.fingerprint ||
        answer.distances[i].rows() != 1 || answer.distances[i].cols() != s.layout.size()) {
      return false;
    }
  }
  return true;
}

// The joint representation of `kind` to attach: of the answers' ones over every place of
// the layout, of its sets, finite and not negative, the one built from the most sets.
void AttachJoint(const PlaceLayout& layout, const std::vector<std::string>& names,
                 const std::vector<std::optional<ShardAnswer>>& answers, JointKind kind,
                 AssembledQuery* query) {
  const int places = layout.num_places();
  const ShardAnswer* best = nullptr;
  size_t best_k = 0;
  for (size_t k = 0; k < answers.size(); ++k) {
    const ShardAnswer* a = answers[k] ? &*answers[k] : nullptr;
    if (!a || !a->error.empty() || a->joint_kind != kind || a->joint_sets.size() < 2 ||
        a->joint_distances.size() != places) {
      continue;
    }
    bool fits = true;
    for (const std::string& name : a->joint_sets) fits = fits && layout.IndexOf(name) >= 0;
    const RowMatrixXf& d = a->joint_distances;
    for (Eigen::Index i = 0; i < d.size(); ++i) {
      fits = fits && d.data()[i] >= 0 && d.data()[i] <= 3.0f;  // within [0, 2]
    }
    if (fits && (!best || a->joint_sets.size() > best->joint_sets.size())) {
      best = a;
      best_k = k;
    }
  }
  if (!best) return;
  // The build names the shard too: another shard's, or its next, starts the state again.
  QueryDistances::Joint joint;
  joint.kind = kind;
  joint.build = (static_cast<uint64_t>(best_k + 1) << 48) ^ best->joint_build;
  joint.distances = Eigen::Map<const RowMatrixXf>(best->joint_distances.data(), 1, places);
  query->distances.SetJoint(std::move(joint));
  query->joint_from = names[best_k] + " (" + std::to_string(best->joint_sets.size()) + " sets)";
}

}  // namespace

AssembledQuery AssembleShardAnswers(const PlaceLayout& layout,
                                    const std::vector<std::string>& names,
                                    const std::vector<const ShardSets*>& shards,
                                    std::vector<std::optional<ShardAnswer>> answers,
                                    DistanceMetric metric, double query_norm,
                                    std::optional<JointKind> joint) {
  if (answers.size() != shards.size() || names.size() != shards.size()) {
    throw std::invalid_argument("AssembleShardAnswers: " + std::to_string(answers.size()) +
                                " answers and " + std::to_string(names.size()) + " names for " +
                                std::to_string(shards.size()) + " shards");
  }
  AssembledQuery query;
  query.distances = QueryDistances(layout.num_sets());
  query.impossible.resize(shards.size());
  std::string refusals;  // of the shards that refused the descriptor
  bool any = false;      // a shard's distances are in
  int u = 0;             // the layout's index of the shard's first set
  for (size_t k = 0; k < shards.size(); ++k) {
    const ShardSets* shard = shards[k];
    if (!shard) {
      query.missing_shards.push_back(names[k]);  // no sets known yet
      continue;
    }
    ShardAnswer* a = answers[k] ? &*answers[k] : nullptr;
    const std::vector<ShardSets::Set>& sets = shard->sets;
    if (a && !a->error.empty() && !sets.empty()) {
      refusals += (refusals.empty() ? "" : "; ") + ("shard " + names[k] + ": " + a->error);
    }
    bool usable = a && AnswersItsSets(*a, *shard);
    // Distances no exact distance can be (a broken kernel, a corrupted message): that
    // shard's fault, not the query's.
    for (size_t i = 0; usable && i < sets.size(); ++i) {
      const RowMatrixXf& d = a->distances[i];
      const std::string problem =
          ShardDistancesProblem(d.data(), static_cast<size_t>(d.size()),
                                metric == DistanceMetric::kCosine, query_norm, sets[i].max_norm);
      if (problem.empty()) continue;
      usable = false;
      query.impossible[k] = "set '" + sets[i].layout.name + "': " + problem;
    }
    if (!usable) {
      if (!sets.empty()) query.missing_shards.push_back(names[k]);
      u += static_cast<int>(sets.size());  // absent
      continue;
    }
    any = any || !sets.empty();
    query.seconds = std::max(query.seconds, a->seconds);
    for (size_t i = 0; i < sets.size(); ++i, ++u) {
      query.distances.Set(u, std::move(a->distances[i]));
    }
  }
  // A descriptor every shard with distances refused is refused; one shard's refusal alone
  // makes that shard missing.
  if (!any && !refusals.empty()) throw std::invalid_argument(refusals);
  if (joint) AttachJoint(layout, names, answers, *joint, &query);
  return query;
}

}  // namespace bsf_vpr
