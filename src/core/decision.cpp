#include "bsf_vpr/core/decision.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bsf_vpr/core/off_map.h"
#include "bsf_vpr/core/sequence_matcher.h"

namespace bsf_vpr {

double Threshold::LogOdds() const {
  if (kind == Kind::kLogOdds) return value;
  return std::log(value) - std::log1p(-value);
}

Threshold Threshold::As(Kind to) const {
  if (to == kind) return *this;
  Threshold t;
  t.kind = to;
  t.value = to == Kind::kLogOdds ? LogOdds() : 1.0 / (1.0 + std::exp(-value));
  return t;
}

void Threshold::Validate() const {
  if (kind == Kind::kProbability && !(value > 0 && value < 1)) {
    throw std::invalid_argument(
        "threshold as a probability (threshold_kind probability) must lie in (0, 1), got " +
        std::to_string(value));
  }
  if (kind == Kind::kLogOdds && !std::isfinite(value)) {
    throw std::invalid_argument("threshold as log-odds (threshold_kind log_odds) must be finite");
  }
}

const EnumNames<Threshold::Kind>& ThresholdKindNames() {
  static const EnumNames<Threshold::Kind> kNames{{Threshold::Kind::kProbability, "probability"},
                                                 {Threshold::Kind::kLogOdds, "log_odds"}};
  return kNames;
}

Threshold::Kind ParseThresholdKind(const std::string& name) {
  return ThresholdKindNames().Parse(name, "threshold_kind");
}

std::string ToString(Threshold::Kind kind) { return ThresholdKindNames().Name(kind); }

Threshold ThresholdAsAsked(const Threshold& before, const Threshold& asked) {
  if (asked.kind == before.kind || asked.value != before.value) return asked;
  const Threshold h = before.As(asked.kind);
  if (h.kind == Threshold::Kind::kProbability && !(h.value < 1)) {
    throw std::invalid_argument(
        "threshold_kind probability: log-odds " + std::to_string(before.value) +
        " is a probability that rounds to 1; send threshold_kind probability with a "
        "threshold below 1 (e.g. 0.999999), or keep log_odds");
  }
  return h;
}

namespace {

// The match ranked first. It is the best place of the unnormalised posterior; normalising
// can round it and a near neighbour to one value, which TopK ranks by index.
void MatchFirst(int match, std::vector<int>* top) {
  if (top->empty() || top->front() == match || match < 0) return;
  const auto it = std::find(top->begin(), top->end(), match);
  if (it != top->end()) {
    std::rotate(top->begin(), it, it + 1);
  } else {
    top->insert(top->begin(), match);
    top->pop_back();
  }
}

// The match, its confidence and whether it passes the threshold (or max_match_distance).
void DecideMatch(const DecisionOptions& options, const Evidence& evidence, PlaceBelief* belief) {
  PlaceBelief& b = *belief;
  switch (evidence.kind) {
    case Evidence::Kind::kPosterior:
      b.confidence = ConfidenceWithOffMap(b.confidence, evidence.log_off_odds);
      b.accepted = b.confidence > options.threshold.LogOdds();
      b.top_places = TopK(b.log_posterior, options.top_k);
      MatchFirst(b.match, &b.top_places);
      return;
    case Evidence::Kind::kDistance:
      b.accepted = std::isfinite(b.confidence) && -b.confidence <= options.max_match_distance;
      b.top_places = TopK(-b.cost, options.top_k);
      return;
    case Evidence::Kind::kSequence: {
      b.top_places = TopK(-b.cost, options.top_k);
      b.accepted = false;
      b.confidence = -std::numeric_limits<double>::infinity();
      if (b.top_places.empty()) return;
      b.match = b.top_places.front();
      b.confidence =
          ConfidenceWithOffMap(SequenceMatchLogOdds(b.cost, b.match, evidence.sequence_velocities),
                               evidence.log_off_odds);
      b.accepted = b.confidence > options.threshold.LogOdds();
      return;
    }
  }
  throw std::logic_error("Decide: unknown kind of evidence");
}

}  // namespace

double AcceptanceRule::Score(double confidence, double match_distance) const {
  if (std::isnan(confidence)) return -std::numeric_limits<double>::infinity();
  const double c = std::clamp(confidence, -confidence_limit, confidence_limit);
  if (w_distance == 0) return w_confidence * c + bias;
  if (!std::isfinite(match_distance)) return -std::numeric_limits<double>::infinity();
  return w_confidence * c + w_distance * match_distance + bias;
}

MatchDistance MatchDistanceOf(const PlaceBelief& belief, const std::vector<SetDistances>& sets,
                              const std::vector<bool>* available) {
  MatchDistance out;
  if (belief.match < 0) return out;
  const std::vector<int>& selected = belief.selection.selected;
  float best = std::numeric_limits<float>::infinity();
  for (int u : belief.used_sets) {
    const size_t k = static_cast<size_t>(u);
    if (k >= sets.size() || (available && !(*available)[k])) continue;
    if (k < belief.set_weights.size() && belief.set_weights[k] < 1 &&
        !std::binary_search(selected.begin(), selected.end(), u)) {
      continue;
    }
    const SetDistances& d = sets[k];
    if (d.values == nullptr) continue;
    for (int r = 0; r < d.count; ++r) {
      if (d.PlaceAt(r) == belief.match && d.values[r] < best) {
        best = d.values[r];
        out.set = u;
      }
    }
  }
  if (out.set >= 0) out.distance = best;
  return out;
}

void Decide(const DecisionOptions& options, const Evidence& evidence, PlaceBelief* belief,
            const AcceptanceRule* rule) {
  DecideMatch(options, evidence, belief);
  PlaceBelief& b = *belief;
  const MatchDistance d =
      evidence.sets ? MatchDistanceOf(b, *evidence.sets, evidence.available) : MatchDistance();
  b.match_distance = d.distance;
  b.match_distance_set = d.set;
  if (rule != nullptr && b.accepted)
    b.accepted = rule->Score(b.confidence, b.match_distance) > rule->cut;
}

}  // namespace bsf_vpr
