// The map calibrates itself (self_calibration.h) and the decision applies its rule
// (decision.h). Synthetic maps: mechanics only; the real-data check is in test_real_data.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bsf_vpr/core/decision.h"
#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/self_calibration.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"
#include "bsf_vpr/evaluation/synthetic.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

PlaceBelief SurePosterior() {
  PlaceBelief b;
  b.log_posterior = Eigen::VectorXd::Constant(4, std::log(0.01));
  b.log_posterior(2) = std::log(0.97);
  b.cost = -b.log_posterior;
  b.match = 2;
  b.confidence = LogOddsOfBest(b.log_posterior, 2);
  b.used_sets = {0, 1};
  b.set_weights = {1, 1};
  return b;
}

TEST(AcceptanceRule, ScoresTheClampedConfidenceAndTheDistance) {
  AcceptanceRule r;
  r.w_confidence = 2;
  r.w_distance = -10;
  r.bias = 1;
  EXPECT_DOUBLE_EQ(r.Score(3, 0.5), 2 * 3 - 5 + 1);
  EXPECT_DOUBLE_EQ(r.Score(1e6, 0), 2 * kMaxScoredConfidence + 1);
  EXPECT_EQ(r.Score(3, kNaN), -kInf);  // the match's distance unknown: never vouched for
  EXPECT_EQ(r.Score(kNaN, 0.5), -kInf);
  r.w_distance = 0;
  EXPECT_DOUBLE_EQ(r.Score(3, kNaN), 7);  // the confidence alone needs no distance
}

TEST(AcceptanceRule, TheMatchDistanceIsTheClosestRowOfTheMatchAmongTheUsedSets) {
  const std::vector<float> a = {0.9f, 0.8f, 0.5f, 0.7f}, b = {0.6f, 0.3f}, c = {0.1f};
  const std::vector<int> b_ids = {2, 3}, c_ids = {2};
  std::vector<SetDistances> sets(3);
  sets[0] = {a.data(), nullptr, 4};
  sets[1] = {b.data(), b_ids.data(), 2};
  sets[2] = {c.data(), c_ids.data(), 1};
  PlaceBelief belief = SurePosterior();  // used: sets 0 and 1; set 2 is closer but unused
  MatchDistance d = MatchDistanceOf(belief, sets);
  EXPECT_FLOAT_EQ(d.distance, 0.5f);
  EXPECT_EQ(d.set, 0);
  belief.used_sets = {0, 1, 2};
  belief.set_weights = {1, 1, 1};
  EXPECT_EQ(MatchDistanceOf(belief, sets).set, 2);
  const std::vector<bool> available = {true, true, false};
  EXPECT_EQ(MatchDistanceOf(belief, sets, &available).set, 0);  // an absent set is skipped
  belief.match = 1;
  belief.used_sets = {1};
  EXPECT_TRUE(std::isnan(MatchDistanceOf(belief, sets).distance));  // set 1 lacks place 1
  EXPECT_EQ(MatchDistanceOf(belief, sets).set, -1);
}

TEST(AcceptanceRule, DecideAcceptsOnlyWhatPassesBothTheThresholdAndTheRule) {
  const std::vector<float> a = {0.9f, 0.8f, 0.5f, 0.7f};
  std::vector<SetDistances> sets(1);
  sets[0] = {a.data(), nullptr, 4};
  Evidence e;
  e.sets = &sets;
  DecisionOptions o;
  AcceptanceRule rule;
  rule.w_distance = -1;  // score = confidence - distance
  PlaceBelief b = SurePosterior();
  b.used_sets = {0};
  b.set_weights = {1};
  const double score = b.confidence - 0.5;
  rule.cut = score - 1e-9;
  PlaceBelief passed = b;
  Decide(o, e, &passed, &rule);
  EXPECT_TRUE(passed.accepted);
  EXPECT_FLOAT_EQ(passed.match_distance, 0.5f);
  rule.cut = score + 1e-9;
  PlaceBelief refused = b;
  Decide(o, e, &refused, &rule);
  EXPECT_FALSE(refused.accepted);
  EXPECT_DOUBLE_EQ(refused.confidence, passed.confidence);  // the rule moves no confidence
  // Below the threshold nothing is accepted, whatever the rule says.
  rule.cut = -kInf;
  o.threshold = {Threshold::Kind::kProbability, 0.99};
  PlaceBelief low = b;
  Decide(o, e, &low, &rule);
  EXPECT_FALSE(low.accepted);
  // Without distances the match's distance is unknown, and a rule that weighs it refuses.
  o.threshold = {Threshold::Kind::kProbability, 0.5};
  PlaceBelief blind = b;
  Decide(o, Evidence{}, &blind, &rule);
  EXPECT_TRUE(std::isnan(blind.match_distance));
  EXPECT_FALSE(blind.accepted);
}

SyntheticData ThreeTraversals(uint64_t seed = 3) {
  SyntheticOptions opt;
  opt.num_places = 150;
  opt.dimension = 24;
  opt.set_noise = {0.35, 0.35, 0.35};
  opt.seed = seed;
  return GenerateMultiConditionData(opt);
}

TEST(SelfCalibration, HoldsOutEveryTraversalAndEveryStretchAndKeepsItsRate) {
  const SyntheticData data = ThreeTraversals();
  const MapCalibration c =
      CalibrateMap(data.map, DistanceMetric::kEuclidean, "bsf+filter", MethodOptions(), 0.05);
  EXPECT_EQ(c.method, "bsf+filter");
  EXPECT_EQ(c.traversals_held_out, 3);
  EXPECT_EQ(c.on_map.size(), 3u * 150);   // each traversal against the other two
  EXPECT_EQ(c.off_map.size(), 3u * 150);  // each row once in a held-out stretch
  EXPECT_TRUE(c.usable());
  // The conformal cut: the held-out rate stays under the target.
  EXPECT_LE(c.off_map_accepted, static_cast<int>(0.05 * c.off_map.size()));
  EXPECT_GT(c.predicted_false_accept_rate, 0);
  EXPECT_LE(c.predicted_false_accept_rate, 0.05 + 1e-12);
  EXPECT_GT(c.recall, 0.5) << c.Summary();
  EXPECT_NE(c.Summary().find("at recall"), std::string::npos) << c.Summary();
  int right = 0;
  for (const CalibrationSample& s : c.on_map) right += s.right;
  EXPECT_GT(right, 300);
  for (const CalibrationSample& s : c.off_map) EXPECT_FALSE(s.right);
  // A looser target cuts lower: more of the held-out rows pass.
  const MapCalibration loose =
      CalibrateMap(data.map, DistanceMetric::kEuclidean, "bsf+filter", MethodOptions(), 0.3);
  EXPECT_LE(loose.rule.cut, c.rule.cut);
  EXPECT_GE(loose.recall, c.recall);
}

// Run live on a new traversal of the route past the map's end, the rule accepts no more of
// the queries that show no place of the map than the map predicted, where the threshold
// alone accepts many (synthetic: the mechanics of hold-out and rule together).
TEST(SelfCalibration, TheRuleHoldsOnNewQueriesThatLeaveTheMap) {
  const SyntheticData data = ThreeTraversals();
  ReferenceSets half;  // the map holds places 0-74 of the route
  for (const StoredReferenceSet& s : data.map.sets()) {
    ReferenceSet r = s.ToReferenceSet();
    ReferenceSet cut;
    cut.name = r.name;
    cut.descriptors = r.descriptors.topRows(75);
    cut.place_ids.assign(r.place_ids.begin(), r.place_ids.begin() + 75);
    half.Add(std::move(cut));
  }
  MethodOptions options;  // the paper's belief: a look-alike takes the whole posterior
  options.off_map.enabled = false;
  options.decision.threshold = {Threshold::Kind::kProbability, 0.5};  // and a lax threshold
  const MapCalibration c =
      CalibrateMap(half, DistanceMetric::kEuclidean, "bsf+filter", options, 0.02);
  ASSERT_TRUE(c.usable()) << c.Summary();
  const std::vector<RowMatrixXf> all =
      ComputeDistances(DistanceMetric::kEuclidean, data.queries, half);
  const Method method = ParseMethod("bsf+filter", half.SetNames());
  int accepted[2] = {0, 0}, right[2] = {0, 0};
  for (int with_rule = 0; with_rule < 2; ++with_rule) {
    MethodRunner runner(method, options);
    if (with_rule) runner.SetAcceptanceRule(c.rule);
    std::vector<const std::vector<int>*> ids;
    for (const StoredReferenceSet& s : half.sets()) ids.push_back(&s.place_ids());
    for (int q = 0; q < static_cast<int>(data.queries.rows()); ++q) {
      const PlaceBelief b =
          runner.Step(QueryRowViews(all, q, ids), half.num_places(), nullptr, std::nullopt, true);
      if (!b.accepted) continue;
      if (q >= 78) ++accepted[with_rule];
      if (q < 75 && std::abs(b.match - q) <= 2) ++right[with_rule];
    }
  }
  std::printf("off-map accepted: %d by the threshold alone, %d with the rule; right: %d, %d\n",
              accepted[0], accepted[1], right[0], right[1]);
  EXPECT_GT(accepted[0], 5) << "the threshold alone should accept look-alikes here";
  EXPECT_LE(accepted[1], 2) << c.Summary();  // 72 off-map queries, a target of 2%
  EXPECT_GT(right[1], 40) << c.Summary();
}

TEST(SelfCalibration, OneTraversalIsMeasuredAgainstItselfAndNotEnforced) {
  SyntheticOptions opt;
  opt.num_places = 120;
  opt.set_noise = {0.3};
  const SyntheticData data = GenerateMultiConditionData(opt);
  const MapCalibration c =
      CalibrateMap(data.map, DistanceMetric::kEuclidean, "bsf", MethodOptions(), 0.05);
  EXPECT_EQ(c.traversals_held_out, 0);
  EXPECT_TRUE(c.on_map.empty());
  EXPECT_EQ(c.off_map.size(), 120u);
  EXPECT_FALSE(c.usable());
  EXPECT_TRUE(std::isnan(c.recall));
  EXPECT_NE(c.Summary().find("one traversal"), std::string::npos) << c.Summary();
}

TEST(SelfCalibration, ATraversalTheMethodNeedsIsNotHeldOutAndBadInputIsRefused) {
  const SyntheticData data = ThreeTraversals();
  const MapCalibration c =
      CalibrateMap(data.map, DistanceMetric::kEuclidean, "nn:c1", MethodOptions(), 0.05);
  EXPECT_EQ(c.traversals_held_out, 2);  // c0 and c2; nn:c1 cannot run without c1
  EXPECT_NE(c.note.find("'c1' against the others not held out"), std::string::npos) << c.note;
  EXPECT_THROW(CalibrateMap(data.map, DistanceMetric::kEuclidean, "bsf", {}, 0),
               std::invalid_argument);
  EXPECT_THROW(CalibrateMap(data.map, DistanceMetric::kEuclidean, "bsf", {}, 1),
               std::invalid_argument);
  EXPECT_THROW(CalibrateMap(ReferenceSets(), DistanceMetric::kEuclidean, "bsf", {}, 0.01),
               std::invalid_argument);
  CalibrationOptions o;
  o.max_false_accept_rate = 1;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

TEST(SelfCalibration, TheEvaluatorAppliesEachMethodsRule) {
  const SyntheticData data = ThreeTraversals();
  std::vector<RowMatrixXf> all;
  EvaluationInput in = testing::ExactEvaluationInput(data, &all);
  const std::vector<Method> methods = {ParseMethod("bsf", in.set_names),
                                       ParseMethod("bsf+filter", in.set_names)};
  const std::vector<MethodResults> free = EvaluateMethods(in, methods, {}, data.truth);
  AcceptanceRule none;
  none.cut = kInf;
  in.acceptance_rules = {std::nullopt, none};
  const std::vector<MethodResults> ruled = EvaluateMethods(in, methods, {}, data.truth);
  int accepted[2] = {0, 0};
  for (int q = 0; q < in.num_queries; ++q) {
    const size_t k = static_cast<size_t>(q);
    EXPECT_EQ(ruled[0].outcomes[k].accepted, free[0].outcomes[k].accepted);
    EXPECT_FALSE(ruled[1].outcomes[k].accepted);
    EXPECT_EQ(ruled[1].outcomes[k].confidence, free[1].outcomes[k].confidence);
    EXPECT_TRUE(std::isfinite(free[0].outcomes[k].match_distance));
    accepted[0] += free[1].outcomes[k].accepted;
  }
  EXPECT_GT(accepted[0], 0);
  in.acceptance_rules = {none};
  EXPECT_THROW(EvaluateMethods(in, methods, {}, data.truth), std::invalid_argument);
}

TEST(SelfCalibration, TooFewOffMapRowsForTheRateAcceptNothingAndSaySo) {
  SyntheticOptions opt;
  opt.num_places = 20;  // 2 x 20 held-out off-map rows cannot vouch for 1% (99 needed)
  opt.set_noise = {0.3, 0.3};
  const SyntheticData data = GenerateMultiConditionData(opt);
  const MapCalibration c =
      CalibrateMap(data.map, DistanceMetric::kEuclidean, "bsf", MethodOptions(), 0.01);
  EXPECT_EQ(c.off_map.size(), 40u);
  EXPECT_TRUE(std::isinf(c.rule.cut) && c.rule.cut > 0);
  EXPECT_EQ(c.predicted_false_accept_rate, 0);
  EXPECT_EQ(c.recall, 0);
  EXPECT_NE(c.Summary().find("nothing is accepted: 40 held-out off-map rows cannot vouch for a "
                             "rate of 1% (99 needed)"),
            std::string::npos)
      << c.Summary();
}

TEST(SelfCalibration, TraversalsOfDisjointStretchesMeasureNoRecallAndAreNotApplied) {
  SyntheticOptions opt;
  opt.num_places = 120;
  opt.set_noise = {0.3, 0.3};
  const SyntheticData data = GenerateMultiConditionData(opt);
  ReferenceSets split;  // c0 shows places 0-59, c1 places 60-119
  for (int u = 0; u < 2; ++u) {
    ReferenceSet r = data.map.set(u).ToReferenceSet();
    ReferenceSet half;
    half.name = r.name;
    half.descriptors = r.descriptors.middleRows(60 * u, 60);
    half.place_ids.assign(r.place_ids.begin() + 60 * u, r.place_ids.begin() + 60 * (u + 1));
    split.Add(std::move(half));
  }
  const MapCalibration c =
      CalibrateMap(split, DistanceMetric::kEuclidean, "bsf", MethodOptions(), 0.05);
  EXPECT_TRUE(c.on_map.empty());  // no other traversal shows a held-out row's place
  EXPECT_FALSE(c.usable());
  EXPECT_NE(c.Summary().find("no other traversal shows"), std::string::npos) << c.Summary();
}

TEST(SelfCalibration, ADistanceMethodsConfidenceIsScoredUnclamped) {
  SyntheticOptions opt;
  opt.num_places = 150;
  opt.set_noise = {0.35, 0.35, 0.35};
  SyntheticData data = GenerateMultiConditionData(opt);
  ReferenceSets far;  // every descriptor 1000 times larger: distances far beyond 30
  for (const StoredReferenceSet& s : data.map.sets()) {
    ReferenceSet r = s.ToReferenceSet();
    r.descriptors *= 1000.0f;
    far.Add(std::move(r));
  }
  MethodOptions options;
  options.decision.max_match_distance = 1e9;  // the rule alone decides
  const MapCalibration c = CalibrateMap(far, DistanceMetric::kEuclidean, "med", options, 0.05);
  ASSERT_TRUE(c.usable()) << c.Summary();
  EXPECT_TRUE(std::isinf(c.rule.confidence_limit));
  EXPECT_GT(c.recall, 0.1) << c.Summary();
  // Clamped at -30, a distance of 1000 and one of 2000 would score alike.
  AcceptanceRule alone = c.rule;
  alone.w_distance = 0;
  EXPECT_GT(alone.Score(-1000, 0), alone.Score(-2000, 0));
}

}  // namespace
}  // namespace bsf_vpr
