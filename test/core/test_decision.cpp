#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>

#include "bsf_vpr/core/decision.h"
#include "bsf_vpr/core/fusion.h"
#include "bsf_vpr/core/off_map.h"
#include "bsf_vpr/core/sequence_matcher.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

// A posterior over five places, normalised, with its best place and log-odds as the fusion
// rules leave them.
PlaceBelief Posterior() {
  PlaceBelief b;
  b.log_posterior.resize(5);
  b.log_posterior << std::log(0.1), std::log(0.6), std::log(0.2), std::log(0.05), std::log(0.05);
  b.cost = -b.log_posterior;
  b.match = 1;
  b.confidence = LogOddsOfBest(b.log_posterior, 1);
  return b;
}

TEST(Decision, AcceptsAPosteriorAboveTheThresholdAndRanksItsPlaces) {
  DecisionOptions o;
  o.top_k = 3;
  o.threshold = {Threshold::Kind::kProbability, 0.5};
  PlaceBelief b = Posterior();
  Decide(o, Evidence{}, &b);
  EXPECT_EQ(b.match, 1);
  EXPECT_NEAR(b.confidence, std::log(0.6 / 0.4), 1e-12);
  EXPECT_TRUE(b.accepted);  // 0.6 > 0.5
  EXPECT_EQ(b.top_places, (std::vector<int>{1, 2, 0}));
  o.threshold = {Threshold::Kind::kProbability, 0.7};
  b = Posterior();
  Decide(o, Evidence{}, &b);
  EXPECT_FALSE(b.accepted);  // 0.6 < 0.7
  // Log-odds given directly: the same rule.
  o.threshold = {Threshold::Kind::kLogOdds, std::log(0.6 / 0.4) - 1e-9};
  b = Posterior();
  Decide(o, Evidence{}, &b);
  EXPECT_TRUE(b.accepted);
}

TEST(Decision, TheMatchRanksFirstWhereNormalisingTiedItWithAnotherPlace) {
  // The fusion picked place 1 on the unnormalised values; normalised, places 0 and 1 came
  // out equal, and TopK alone would rank place 0 first.
  PlaceBelief b;
  b.log_posterior.resize(3);
  b.log_posterior << std::log(0.4), std::log(0.4), std::log(0.2);
  b.match = 1;
  b.confidence = 0.0;
  DecisionOptions o;
  o.top_k = 3;
  Decide(o, Evidence{}, &b);
  EXPECT_EQ(b.top_places, (std::vector<int>{1, 0, 2}));
  b.top_places.clear();
  o.top_k = 1;  // the match even where the tie would have left it out
  Decide(o, Evidence{}, &b);
  EXPECT_EQ(b.top_places, (std::vector<int>{1}));
}

TEST(Decision, TheOffMapOddsLowerTheConfidenceAndCanRefuseTheMatch) {
  DecisionOptions o;
  o.threshold = {Threshold::Kind::kProbability, 0.5};
  Evidence e;
  e.log_off_odds = std::log(1.0);  // P(off) = 0.5: P(match) = 0.5 * 0.6 = 0.3
  PlaceBelief b = Posterior();
  Decide(o, e, &b);
  EXPECT_NEAR(b.confidence, std::log(0.3 / 0.7), 1e-12);
  EXPECT_EQ(b.confidence, ConfidenceWithOffMap(std::log(0.6 / 0.4), std::log(1.0)));
  EXPECT_FALSE(b.accepted);
  EXPECT_EQ(b.match, 1);  // the place is still the best among the places
}

TEST(Decision, ADistanceMethodIsAcceptedWithinTheLargestDistance) {
  PlaceBelief b;
  b.cost.resize(4);
  b.cost << 0.5, 0.2, std::numeric_limits<double>::infinity(), 0.3;
  b.match = 1;
  b.confidence = -0.2;
  DecisionOptions o;
  o.top_k = 10;
  o.max_match_distance = 0.2;
  Decide(o, Evidence{Evidence::Kind::kDistance}, &b);
  EXPECT_TRUE(b.accepted);
  EXPECT_EQ(b.top_places, (std::vector<int>{1, 3, 0}));  // an uncovered place never ranks
  o.max_match_distance = 0.19;
  Decide(o, Evidence{Evidence::Kind::kDistance}, &b);
  EXPECT_FALSE(b.accepted);
  b.confidence = -std::numeric_limits<double>::infinity();
  o.max_match_distance = std::numeric_limits<double>::max();
  Decide(o, Evidence{Evidence::Kind::kDistance}, &b);
  EXPECT_FALSE(b.accepted);  // never a non-finite match
}

TEST(Decision, ASequenceIsDecidedOnItsOwnCostsAndOdds) {
  PlaceBelief b;
  b.cost = Eigen::VectorXd::LinSpaced(30, 10.0, 40.0);
  b.cost(17) = 0.5;  // a sequence far better than the others
  b.match = 3;       // the single query's match: replaced
  Evidence e;
  e.kind = Evidence::Kind::kSequence;
  e.sequence_velocities = 3;
  DecisionOptions o;
  o.top_k = 2;
  Decide(o, e, &b);
  EXPECT_EQ(b.match, 17);
  EXPECT_EQ(b.top_places, (std::vector<int>{17, 0}));
  EXPECT_EQ(b.confidence, SequenceMatchLogOdds(b.cost, 17, 3));
  EXPECT_EQ(b.accepted, b.confidence > o.threshold.LogOdds());
  ASSERT_TRUE(std::isfinite(b.confidence));
  o.threshold = {Threshold::Kind::kLogOdds, b.confidence - 1e-9};
  Decide(o, e, &b);
  EXPECT_TRUE(b.accepted);
  o.threshold = {Threshold::Kind::kLogOdds, b.confidence};
  Decide(o, e, &b);
  EXPECT_FALSE(b.accepted);  // strictly above h
  // No place possible: nothing accepted, no finite confidence.
  b.cost = Eigen::VectorXd::Constant(4, std::numeric_limits<double>::infinity());
  Decide(o, e, &b);
  EXPECT_FALSE(b.accepted);
  EXPECT_TRUE(b.top_places.empty());
  EXPECT_EQ(b.confidence, -std::numeric_limits<double>::infinity());
}

TEST(Decision, ThresholdKindsConvertAndValidate) {
  EXPECT_NEAR((Threshold{Threshold::Kind::kProbability, 0.5}.LogOdds()), 0.0, 1e-12);
  EXPECT_NEAR((Threshold{Threshold::Kind::kProbability, 0.9}.LogOdds()), std::log(9.0), 1e-12);
  EXPECT_THROW((Threshold{Threshold::Kind::kProbability, 1.0}.Validate()), std::invalid_argument);
  EXPECT_EQ(ParseThresholdKind("log_odds"), Threshold::Kind::kLogOdds);
  EXPECT_EQ(ToString(Threshold::Kind::kProbability), "probability");
  EXPECT_THROW(ParseThresholdKind("logodds"), std::invalid_argument);
  // The same threshold in the other kind's units, both ways.
  const Threshold p{Threshold::Kind::kProbability, 0.9};
  const Threshold l = p.As(Threshold::Kind::kLogOdds);
  EXPECT_EQ(l.kind, Threshold::Kind::kLogOdds);
  EXPECT_NEAR(l.value, std::log(9.0), 1e-12);
  EXPECT_NEAR(l.As(Threshold::Kind::kProbability).value, 0.9, 1e-12);
  EXPECT_EQ(p.As(Threshold::Kind::kProbability).value, 0.9);
  EXPECT_THROW(
      (Threshold{Threshold::Kind::kLogOdds, 40}.As(Threshold::Kind::kProbability).Validate()),
      std::invalid_argument);  // rounds to 1
}

TEST(Decision, AKindSwitchedAloneKeepsTheThresholdAndAnythingElseIsTakenAsAsked) {
  const Threshold before{Threshold::Kind::kProbability, 0.9};
  const Threshold switched = ThresholdAsAsked(before, {Threshold::Kind::kLogOdds, 0.9});
  EXPECT_EQ(switched.kind, Threshold::Kind::kLogOdds);
  EXPECT_NEAR(switched.value, std::log(9.0), 1e-12);
  const Threshold both = ThresholdAsAsked(before, {Threshold::Kind::kLogOdds, 3.0});
  EXPECT_EQ(both.value, 3.0);  // a new value with the new kind: as asked
  const Threshold value = ThresholdAsAsked(before, {Threshold::Kind::kProbability, 0.95});
  EXPECT_EQ(value.value, 0.95);
  // log-odds 40 is a probability that rounds to 1: refused, naming the way out.
  try {
    ThresholdAsAsked({Threshold::Kind::kLogOdds, 40}, {Threshold::Kind::kProbability, 40});
    FAIL() << "a probability that rounds to 1 was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("rounds to 1"), std::string::npos);
  }
}

}  // namespace
}  // namespace bsf_vpr
