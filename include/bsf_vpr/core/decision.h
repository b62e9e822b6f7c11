// The decision: the one step that turns what a method found (a posterior over places, a
// distance method's mean distances, a sequence's costs), with the off-map tracker's odds,
// into the match, its confidence, whether it is accepted (with the map's own rule, where it
// has one: AcceptanceRule) and the ranked places. Nothing else sets PlaceBelief::accepted or
// top_places, and no other step of a query reads threshold, threshold_kind,
// max_match_distance and top_k (the options' validation and the
// node's reconfiguration check them; docs/method.md, "Confidence and acceptance").
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/fusion.h"

namespace bsf_vpr {

// The threshold h of the paper on a Bayesian method's belief in its best place. Given as a
// posterior probability p in (0, 1) or directly as log-odds log(p / (1 - p)). A match is
// accepted when the confidence (log-odds) exceeds LogOdds().
struct Threshold {
  enum class Kind { kProbability, kLogOdds };
  Kind kind = Kind::kProbability;
  double value = 0.9;

  double LogOdds() const;
  // The same threshold given as `to` says (log-odds 2.197 is probability 0.9). A large
  // log-odds becomes a probability that rounds to 1, which Validate() refuses.
  Threshold As(Kind to) const;
  // Throws std::invalid_argument: a probability must lie in (0, 1), log-odds be finite.
  void Validate() const;
};
// The kinds' names (threshold_kind).
const EnumNames<Threshold::Kind>& ThresholdKindNames();
Threshold::Kind ParseThresholdKind(const std::string& name);  // throws naming the choices
std::string ToString(Threshold::Kind kind);

// A change of threshold asked for live (dynamic_reconfigure): `asked` as the request left it,
// `before` the one in force. threshold_kind switched alone (the value unchanged) means the
// same threshold in the other kind's units; anything else is taken as asked. Throws
// std::invalid_argument when the switch gives a probability that rounds to 1.
Threshold ThresholdAsAsked(const Threshold& before, const Threshold& asked);

// What accepts a match and how many places are ranked (MethodOptions::decision).
struct DecisionOptions {
  Threshold threshold;  // h: Bayesian methods and every +seq method (probability or log-odds)
  // Distance methods (nn:, med, med_selective) without +seq: the largest (mean) distance of
  // an accepted match, in the distance's own units (not squared). The default 0 accepts
  // only a query identical to a reference: set it for the descriptor and distance in use.
  double max_match_distance = 0;
  int top_k = 10;  // how many ranked places to return (recall@K needs K)
};

// What the decision is made from, besides the belief the method filled.
struct Evidence {
  enum class Kind {
    // belief.log_posterior (normalised), with the posterior's best place and its log-odds in
    // belief.match and belief.confidence (NormalizePosterior)
    kPosterior,
    // belief.cost: a distance method's mean distance per place, its best place and minus
    // its distance in belief.match and belief.confidence
    kDistance,
    // belief.cost: the best sequence's cost ending at each place (SequenceMatcher::Push)
    kSequence,
  };
  Kind kind = Kind::kPosterior;
  // log(P(off) / P(on)) from the off-map tracker; -infinity without the hypothesis.
  double log_off_odds = -std::numeric_limits<double>::infinity();
  // kSequence: the velocities each place's sequence was searched over
  // (SequenceMatcher::velocities).
  int sequence_velocities = 1;
  // The query's distances to the sets (null: none given), `available` marking those it has
  // (null: all): the match's distance (PlaceBelief::match_distance) is read from them.
  const std::vector<SetDistances>* sets = nullptr;
  const std::vector<bool>* available = nullptr;
};

// The map's own acceptance rule (self_calibration.h), learnt by holding its traversals and
// places out: a match is accepted only if, besides passing the threshold,
//   w_confidence * min(max(confidence, -confidence_limit), confidence_limit)
//     + w_distance * match_distance + bias > cut.
// The score is the log-odds that the match is right given the two (a logistic fit); with
// w_distance 0 it is the confidence alone. cut = +infinity accepts nothing.
struct AcceptanceRule {
  // Bayesian and +seq methods: kMaxScoredConfidence; a distance method's confidence (minus
  // its distance) is not clamped: +infinity.
  double confidence_limit = 30;
  double w_confidence = 1;
  double w_distance = 0;
  double bias = 0;
  double cut = -std::numeric_limits<double>::infinity();

  // NaN match_distance (no used set covers the match): -infinity unless w_distance is 0.
  double Score(double confidence, double match_distance) const;
};
// Confidences beyond this are scored as this (+-): a match of log-odds 30 is as sure as
// one of 300, and a fit of the score stays finite.
constexpr double kMaxScoredConfidence = 30;

// The match's distance: the smallest distance of the query to a row showing the match among
// the sets the method relied on (used_sets; a mixture's used sets of weight below 1 only
// when also selected), with the set it came from; {NaN, -1} if none covers the match.
struct MatchDistance {
  double distance = std::numeric_limits<double>::quiet_NaN();
  int set = -1;
};
MatchDistance MatchDistanceOf(const PlaceBelief& belief, const std::vector<SetDistances>& sets,
                              const std::vector<bool>* available = nullptr);

// Decides: sets match, confidence, match_distance (and its set), accepted and top_places of `belief` (see
// PlaceBelief). With `rule`, an accepted match must pass it too.
void Decide(const DecisionOptions& options, const Evidence& evidence, PlaceBelief* belief,
            const AcceptanceRule* rule = nullptr);

}  // namespace bsf_vpr
