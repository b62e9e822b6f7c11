#include "bsf_vpr/core/methods.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace bsf_vpr {

std::string Method::Name() const {
  return BaseName() + (temporal_filter ? "+filter" : "") + (sequence ? "+seq" : "");
}

namespace {

// Whether a method of this kind runs on one set, named after a colon: nn:<set>, bayes:<set>.
bool NamesASet(MethodKind kind) {
  return kind == MethodKind::kNearestNeighbour || kind == MethodKind::kBayesSingle;
}

// The methods as messages list them: "bsf, ..., bayes:<set> or nn:<set>".
std::string ListedMethods() {
  const std::vector<EnumNames<MethodKind>::Entry>& entries = MethodKindNames().entries();
  std::string out;
  for (size_t i = 0; i < entries.size(); ++i) {
    if (i > 0) out += i + 1 == entries.size() ? " or " : ", ";
    out += std::string(entries[i].second) + (NamesASet(entries[i].first) ? ":<set>" : "");
  }
  return out;
}

}  // namespace

const EnumNames<MethodKind>& MethodKindNames() {
  static const EnumNames<MethodKind> kNames{{MethodKind::kBsf, "bsf"},
                                            {MethodKind::kBayesFull, "bayes_full"},
                                            {MethodKind::kMed, "med"},
                                            {MethodKind::kMedSelective, "med_selective"},
                                            {MethodKind::kMeanDescriptor, "mean_descriptor"},
                                            {MethodKind::kUnionNn, "union_nn"},
                                            {MethodKind::kSubspace, "subspace"},
                                            {MethodKind::kDiscriminant, "discriminant"},
                                            {MethodKind::kBayesSingle, "bayes"},
                                            {MethodKind::kNearestNeighbour, "nn"}};
  return kNames;
}

std::string Method::BaseName() const {
  const std::string name = MethodKindNames().Name(kind);
  return NamesASet(kind) ? name + ":" + set_name : name;
}

bool Method::IsBayesian() const {
  return kind != MethodKind::kNearestNeighbour && kind != MethodKind::kMed &&
         kind != MethodKind::kMedSelective;
}

bool Method::NeedsSharedPlaces() const {
  return kind == MethodKind::kMeanDescriptor || kind == MethodKind::kUnionNn ||
         kind == MethodKind::kSubspace || kind == MethodKind::kDiscriminant;
}

std::optional<JointKind> Method::JointNeeded(const MethodOptions& options) const {
  switch (kind) {
    case MethodKind::kMeanDescriptor:
      return JointKind::kMeanDescriptor;
    case MethodKind::kSubspace:
      return JointKind::kSubspace;
    case MethodKind::kDiscriminant:
      return JointKind::kDiscriminant;
    case MethodKind::kBsf:
      if (options.fusion == FusionRule::kAdaptive) return ToJointKind(options.fusion_joint);
      return std::nullopt;
    default:
      return std::nullopt;
  }
}

const EnumNames<FusionJoint>& FusionJointNames() {
  static const EnumNames<FusionJoint> kNames{{FusionJoint::kNone, "none"},
                                             {FusionJoint::kMeanDescriptor, "mean_descriptor"},
                                             {FusionJoint::kSubspace, "subspace"},
                                             {FusionJoint::kDiscriminant, "discriminant"}};
  return kNames;
}

std::optional<JointKind> ToJointKind(FusionJoint joint) {
  switch (joint) {
    case FusionJoint::kMeanDescriptor:
      return JointKind::kMeanDescriptor;
    case FusionJoint::kSubspace:
      return JointKind::kSubspace;
    case FusionJoint::kDiscriminant:
      return JointKind::kDiscriminant;
    case FusionJoint::kNone:
      break;
  }
  return std::nullopt;
}

namespace {

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

Method ParseMethod(const std::string& full_name, const std::vector<std::string>& set_names) {
  Method m;
  std::string name = full_name;
  for (;;) {  // suffixes, in any order
    const size_t plus = name.rfind('+');
    if (plus == std::string::npos) break;
    const std::string suffix = name.substr(plus + 1);
    if (suffix == "filter") {
      m.temporal_filter = true;
    } else if (suffix == "seq") {
      m.sequence = true;
    } else {
      throw std::invalid_argument("unknown method suffix '+" + suffix + "' in '" + full_name +
                                  "' (expected +filter or +seq)");
    }
    name.resize(plus);
  }
  // The method's name, then after a colon its set's for the methods that name one.
  const size_t colon = name.find(':');
  const std::optional<MethodKind> kind = MethodKindNames().Find(name.substr(0, colon));
  if (!kind || NamesASet(*kind) != (colon != std::string::npos)) {
    throw std::invalid_argument("unknown method '" + full_name + "' (expected " + ListedMethods() +
                                ")");
  }
  m.kind = *kind;
  if (NamesASet(m.kind)) {
    m.set_name = name.substr(colon + 1);
    const auto it = std::find(set_names.begin(), set_names.end(), m.set_name);
    if (it == set_names.end()) {
      throw std::invalid_argument("method '" + name + "' names an unknown reference set '" +
                                  m.set_name + "' (loaded: " + JoinNames(set_names) + ")");
    }
    m.set_index = static_cast<int>(it - set_names.begin());
  }
  if (m.temporal_filter && !m.IsBayesian()) {
    throw std::invalid_argument("method '" + full_name +
                                "': +filter needs a Bayesian method (a posterior to carry)");
  }
  return m;
}

namespace {

// A method of `kind` with every other field at its default.
Method MethodOfKind(MethodKind kind) {
  Method m;
  m.kind = kind;
  return m;
}

}  // namespace

std::vector<Method> AllMethods(const std::vector<std::string>& set_names, bool joint_methods) {
  std::vector<Method> out;
  for (const auto& [kind, name] : MethodKindNames().entries()) {
    if (NamesASet(kind)) {
      for (const std::string& s : set_names) {
        out.push_back(ParseMethod(std::string(name) + ":" + s, set_names));
      }
    } else if (joint_methods || !MethodOfKind(kind).NeedsSharedPlaces()) {
      out.push_back(ParseMethod(name, set_names));
    }
  }
  return out;
}

std::vector<Method> ParseMethodList(const std::string& list,
                                    const std::vector<std::string>& set_names, bool joint_methods) {
  if (list.empty() || list == "all") return AllMethods(set_names, joint_methods);
  std::vector<Method> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    // "all" may be combined with other names (all,bsf+filter); a repeated method is kept once,
    // where it first appears.
    const std::vector<Method> items = item == "all"
                                          ? AllMethods(set_names, joint_methods)
                                          : std::vector<Method>{ParseMethod(item, set_names)};
    for (const Method& m : items) {
      const bool dup = std::any_of(out.begin(), out.end(),
                                   [&](const Method& o) { return o.Name() == m.Name(); });
      if (!dup) out.push_back(m);
    }
  }
  if (out.empty()) throw std::invalid_argument("the method list '" + list + "' names no method");
  return out;
}

const OptionTable<MethodOptions>& MethodOptionsTable() {
  constexpr bool kLive = true;
  static const OptionTable<MethodOptions> kTable =
      OptionTable<MethodOptions>()
          .Include(
              SelectionOptionsTable(), [](auto& o) -> auto& { return o.selection; })
          .AddChoice(
              "fusion", [](auto& o) -> auto& { return o.fusion; },
              "how bsf fuses the sets: adaptive (Bayesian model averaging over the queries "
              "so far of three hypotheses: the query shows one set's condition, one of them "
              "uncertainly (the mixture), or the sets are independent evidence (their "
              "product), each weighted by how well it predicted the queries; docs/method.md), "
              "mixture (sets of one descriptor are alternative conditions of the query: their "
              "likelihoods are mixed, weighted by the soft form of the selection rule, with "
              "the non-match statistics pooled) or product (exactly the paper: the selected "
              "sets' likelihoods multiply)",
              FusionRuleNames(), kLive)
          .Add(
              "fusion_memory_queries", [](auto& o) -> auto& { return o.adaptive.memory_queries; },
              "fusion adaptive: the queries over which a hypothesis's predictions count (its "
              "score forgets by 1 - 1 / this per query)",
              "queries", AtLeast(1), kLive)
          .Add(
              "fusion_place_means", [](auto& o) -> auto& { return o.adaptive.place_means; },
              "fusion adaptive: correct each place's distances by its mean distance to the "
              "queries so far, so that a reference image near every query (a hub) stops posing "
              "as the match; a query showing the same scene as the last one counted (a robot "
              "standing still) is not counted",
              "", {}, kLive)
          .Add(
              "fusion_place_prior_queries",
              [](auto& o) -> auto& { return o.adaptive.place_prior_queries; },
              "fusion adaptive with fusion_place_means: the queries counted after which a "
              "place's own mean counts half (the correction is n / (n + this) of it)",
              "queries", AtLeast(1), kLive)
          .AddChoice(
              "fusion_joint", [](auto& o) -> auto& { return o.fusion_joint; },
              "fusion adaptive: what the sets share, built from their descriptors, as one more "
              "hypothesis beside the sets' (the query is best told by the joint "
              "representation), with its own likelihood, weighted as the others by how well "
              "it predicts the queries: discriminant, mean_descriptor, subspace or none (the "
              "sets alone); needs sets of one descriptor that share places, else the sets "
              "alone are fused",
              FusionJointNames(), kLive)
          .Include(
              JointOptionsTable(), [](auto& o) -> auto& { return o.joint; })
          .AddChoice(
              "likelihood", [](auto& o) -> auto& { return o.likelihood.variant; },
              "likelihood variant: one_sided (no credit for the upper tail) or two_sided "
              "(exactly the paper)",
              LikelihoodVariantNames(), kLive)
          .Add(
              "threshold", [](auto& o) -> auto& { return o.decision.threshold.value; },
              "threshold h on the match, given as threshold_kind says (a probability in (0, 1) "
              "or finite log-odds); gates the Bayesian methods and every +seq method",
              "", Finite(), kLive)
          .AddChoice(
              "threshold_kind", [](auto& o) -> auto& { return o.decision.threshold.kind; },
              "how threshold is given: probability (a posterior in (0, 1)) or log_odds "
              "(log(p / (1 - p)), any finite number)",
              ThresholdKindNames(), kLive)
          .Add(
              "max_match_distance", [](auto& o) -> auto& { return o.decision.max_match_distance; },
              "distance methods (nn:<set>, med, med_selective): the largest (mean) distance of "
              "an accepted match, in the distance's units (0: only an identical image)",
              "distance units", AtLeast(0), kLive)
          .Add(
              "top_k", [](auto& o) -> auto& { return o.decision.top_k; },
              "ranked places kept per query (recall@K needs K)", "places", AtLeast(1))
          .Include(
              SequenceOptionsTable(), [](auto& o) -> auto& { return o.sequence; })
          .Include(
              TemporalFilterOptionsTable(), [](auto& o) -> auto& { return o.filter; })
          .Include(
              OffMapOptionsTable(), [](auto& o) -> auto& { return o.off_map; });
  return kTable;
}

void MethodOptions::Validate() const {
  MethodOptionsTable().CheckValues(*this);  // each field's bounds, the parts' fields too
  decision.threshold.Validate();            // the rules across fields
  joint.Validate();
  sequence.Validate();
}

bool Method::CarriesState(const MethodOptions& options) const {
  return temporal_filter || sequence ||
         (kind == MethodKind::kBsf && options.fusion == FusionRule::kAdaptive) ||
         (IsBayesian() && options.off_map.enabled);
}

namespace {

// Per place the smallest distance over every set that covers it (each place covered by some
// set: a place no set covers gets the largest distance of the query). Throws when the sets
// are of different groups or no place is covered by two of them.
std::vector<float> UnionDistances(const std::vector<SetDistances>& sets, int num_places) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> out(static_cast<size_t>(num_places), inf);
  std::vector<int> covered(static_cast<size_t>(num_places), 0);
  float largest = 0;
  for (const SetDistances& d : sets) {
    if (d.group != sets.front().group) {
      throw std::invalid_argument(
          "union_nn needs sets of one descriptor (one distance scale); these are of several");
    }
    for (int k = 0; k < d.count; ++k) {
      const int p = d.PlaceAt(k);
      if (p < 0 || p >= num_places) {
        throw std::invalid_argument("a set names place " + std::to_string(p) + " of a map of " +
                                    std::to_string(num_places));
      }
      out[static_cast<size_t>(p)] = std::min(out[static_cast<size_t>(p)], d.values[k]);
      largest = std::max(largest, d.values[k]);
    }
  }
  int shared = 0;
  for (const SetDistances& d : sets) {
    for (int k = 0; k < d.count; ++k)
      shared = std::max(shared, ++covered[static_cast<size_t>(d.PlaceAt(k))]);
  }
  if (sets.size() < 2 || shared < 2) {
    throw std::invalid_argument("union_nn needs two or more sets that show the same places");
  }
  for (float& v : out) {
    if (v == inf) v = largest;
  }
  return out;
}

const JointDistances* FindJoint(const std::vector<JointDistances>* joint, JointKind kind,
                                int num_places) {
  if (joint == nullptr) return nullptr;
  for (const JointDistances& j : *joint) {
    if (j.kind != kind) continue;
    if (j.distances.count != num_places || j.distances.place_ids != nullptr) {
      throw std::invalid_argument("the " + ToString(kind) + " distances cover " +
                                  std::to_string(j.distances.count) + " places of " +
                                  std::to_string(num_places));
    }
    return &j;
  }
  return nullptr;
}

// bsf with fusion adaptive: the hypotheses of each group averaged by their scores.
void RunAdaptive(const std::vector<SetDistances>& sets, int num_places,
                 const MethodOptions& options, const Eigen::VectorXd* log_prior,
                 const FusionStream* stream, const JointDistances* source, PlaceBelief* out) {
  const std::vector<double> weights =
      ConditionWeights(sets, out->selection.set_stats, options.selection);
  const FusionStream none;
  const FusionStream& s = stream ? *stream : none;
  AdaptiveFusion::Query query(sets, out->selection.set_stats, weights, num_places);
  query.set_ids = s.set_ids;
  query.joint = source ? &source->distances : nullptr;
  query.log_prior = log_prior;
  query.step_places = s.step_places;
  query.likelihood = options.likelihood;
  query.filter = options.filter;
  AdaptiveFusion first;  // without a stream: the first query of one
  (s.state ? s.state : &first)->Fuse(query, options.adaptive, s.update_state, out);
}

// The methods of one source built from every set (union_nn, the joint representations).
void RunOnSharedPlaces(const Method& method, const std::vector<SetDistances>& sets,
                       int num_places, const MethodOptions& options,
                       const Eigen::VectorXd* log_prior, const JointDistances* source,
                       PlaceBelief* out) {
  std::vector<float> union_values;
  std::vector<SetDistances> one(1);
  if (method.kind == MethodKind::kUnionNn) {
    union_values = UnionDistances(sets, num_places);
    one[0].values = union_values.data();
    one[0].count = num_places;
  } else if (source == nullptr) {
    throw std::invalid_argument(
        "method '" + method.Name() + "' needs the " + ToString(*method.JointNeeded(options)) +
        " representation of the sets, which is not built (it needs the sets' descriptors, of "
        "sets that share places)");
  } else {
    one[0] = source->distances;
  }
  out->used_sets.resize(sets.size());
  std::iota(out->used_sets.begin(), out->used_sets.end(), 0);
  out->set_weights.assign(sets.size(), 1.0);
  FuseBayes(one, {0}, num_places, options.likelihood, log_prior, out);
}

// The sets a method of the paper fuses (nn:, bayes:, med, bayes_full, med_selective, bsf).
std::vector<int> SetsUsed(const Method& method, const std::vector<SetDistances>& sets,
                          const Selection& selection) {
  switch (method.kind) {
    case MethodKind::kNearestNeighbour:
    case MethodKind::kBayesSingle:
      if (method.set_index < 0 || method.set_index >= static_cast<int>(sets.size())) {
        throw std::invalid_argument("method '" + method.Name() + "' refers to a set index " +
                                    std::to_string(method.set_index) + " that is not loaded");
      }
      return {method.set_index};
    case MethodKind::kMed:
    case MethodKind::kBayesFull: {
      std::vector<int> all(sets.size());
      std::iota(all.begin(), all.end(), 0);
      return all;
    }
    case MethodKind::kMedSelective:
    case MethodKind::kBsf:
      return selection.selected;
    default:
      throw std::logic_error("RunMethod: a method of the joint sources reached the sets' path");
  }
}

}  // namespace

PlaceBelief RunMethod(const Method& method, const std::vector<SetDistances>& sets, int num_places,
                      const MethodOptions& options, const Eigen::VectorXd* log_prior,
                      const FusionStream* stream, const std::vector<JointDistances>* joint) {
  PlaceBelief out;
  const std::optional<JointKind> joint_kind = method.JointNeeded(options);
  const JointDistances* source = joint_kind ? FindJoint(joint, *joint_kind, num_places) : nullptr;
  const bool adaptive = method.kind == MethodKind::kBsf && options.fusion == FusionRule::kAdaptive;
  const bool mixture =
      method.kind == MethodKind::kBsf && (options.fusion == FusionRule::kMixture || adaptive);
  // Selection is computed for every method: it is cheap and its statistics (u*, min D^u)
  // are reported with every belief. The mixture selects within each descriptor group.
  out.selection = SelectReferenceSets(sets, options.selection, mixture);
  if (adaptive) {
    RunAdaptive(sets, num_places, options, log_prior, stream, source, &out);
    return out;
  }
  if (method.NeedsSharedPlaces()) {  // one source built from every set
    RunOnSharedPlaces(method, sets, num_places, options, log_prior, source, &out);
    return out;
  }
  if (mixture) {
    out.set_weights = ConditionWeights(sets, out.selection.set_stats, options.selection);
    for (size_t u = 0; u < sets.size(); ++u) {
      if (out.set_weights[u] > 0) out.used_sets.push_back(static_cast<int>(u));
    }
    FuseMixture(sets, out.set_weights, num_places, options.likelihood, log_prior, &out,
                out.selection.set_stats);
    return out;
  }
  const std::vector<int> use = SetsUsed(method, sets, out.selection);
  out.used_sets = use;
  out.set_weights.assign(sets.size(), 0.0);
  for (int u : use) out.set_weights.at(static_cast<size_t>(u)) = 1.0;
  if (method.IsBayesian()) {
    // The statistics selection computed for every set are the likelihood's too: an input,
    // taken aside rather than read out of the belief FuseBayes fills.
    const std::vector<DistanceStats> set_stats = out.selection.set_stats;
    FuseBayes(sets, use, num_places, options.likelihood, log_prior, &out, &set_stats);
  } else {
    FuseMinEnsembleDistance(sets, use, num_places, &out);
  }
  return out;
}

}  // namespace bsf_vpr
