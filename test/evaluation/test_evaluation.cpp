#include <gtest/gtest.h>

#include "bsf_vpr/evaluation/evaluation.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"

namespace bsf_vpr {
namespace {

TEST(Evaluation, HandWorkedPrecisionRecallWithTies) {
  // Five queries, four with a true match; two tied confidences are accepted together.
  const std::vector<double> conf = {0.9, 0.8, 0.8, 0.5, 0.1};
  const std::vector<bool> correct = {true, false, true, true, false};
  const auto curve = PrecisionRecallCurve(conf, correct, 4);
  ASSERT_EQ(curve.size(), 5u);  // start + 4 distinct confidences
  EXPECT_DOUBLE_EQ(curve[0].recall, 0.0);
  EXPECT_DOUBLE_EQ(curve[0].precision, 1.0);
  EXPECT_DOUBLE_EQ(curve[1].recall, 0.25);
  EXPECT_DOUBLE_EQ(curve[1].precision, 1.0);
  EXPECT_DOUBLE_EQ(curve[2].recall, 0.5);
  EXPECT_DOUBLE_EQ(curve[2].precision, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(curve[3].precision, 0.75);
  EXPECT_DOUBLE_EQ(curve[4].precision, 0.6);
  EXPECT_DOUBLE_EQ(curve[4].recall, 0.75);
  const double auc = 0.25 * 1.0 + 0.25 * (1.0 + 2.0 / 3.0) / 2 + 0.25 * (2.0 / 3.0 + 0.75) / 2;
  EXPECT_NEAR(AreaUnderCurve(curve), auc, 1e-12);
  EXPECT_DOUBLE_EQ(RecallAtFullPrecision(curve), 0.25);
}

TEST(Evaluation, PerfectAndAllTiedCases) {
  const auto perfect = PrecisionRecallCurve({3, 2, 1}, {true, true, true}, 3);
  EXPECT_NEAR(AreaUnderCurve(perfect), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(RecallAtFullPrecision(perfect), 1.0);
  // All tied: a single operating point at precision 0.5, recall 0.5.
  const auto tied = PrecisionRecallCurve({1, 1, 1, 1}, {true, false, true, false}, 4);
  ASSERT_EQ(tied.size(), 2u);
  EXPECT_NEAR(AreaUnderCurve(tied), 0.5 * (1 + 0.5) / 2, 1e-12);
  EXPECT_DOUBLE_EQ(RecallAtFullPrecision(tied), 0.0);
  const auto first_wrong = PrecisionRecallCurve({2, 1}, {false, true}, 2);
  EXPECT_DOUBLE_EQ(RecallAtFullPrecision(first_wrong), 0.0);
}

TEST(Evaluation, FrameToleranceAndRecallAtK) {
  const GroundTruth t = GroundTruth::FromFrameTolerance(6, 5, 1);
  EXPECT_TRUE(t.IsCorrect(0, 1));
  EXPECT_FALSE(t.IsCorrect(0, 2));
  EXPECT_EQ(t.CorrectPlaces(4), (std::vector<int>{3, 4}));
  EXPECT_FALSE(t.HasTrueMatch(5));  // more queries than places
  EXPECT_EQ(t.NumWithTrueMatch(), 5);
  const std::vector<std::vector<int>> ranked = {{3, 0}, {1}, {4, 4, 2}, {0, 1, 2, 3, 4}, {4}, {0}};
  EXPECT_DOUBLE_EQ(RecallAtK(ranked, t, 1), 2.0 / 5.0);  // queries 1 and 4
  EXPECT_DOUBLE_EQ(RecallAtK(ranked, t, 2), 3.0 / 5.0);  // and query 0
  EXPECT_DOUBLE_EQ(RecallAtK(ranked, t, 5), 5.0 / 5.0);
  EXPECT_THROW(GroundTruth::FromFrameTolerance(3, 3, -1), std::invalid_argument);
}

TEST(Evaluation, MetricToleranceUsesPlacePoses) {
  std::vector<std::optional<PlacePose>> places = {PlacePose{0, 0, 0, 0}, PlacePose{5, 0, 0, 0},
                                                  std::nullopt, PlacePose{30, 0, 0, 0}};
  const GroundTruth t =
      GroundTruth::FromMetricTolerance({{4, 0, 0, 0}, {100, 0, 0, 0}}, places, 10);
  EXPECT_EQ(t.CorrectPlaces(0), (std::vector<int>{0, 1}));
  EXPECT_FALSE(t.HasTrueMatch(1));
  // Planar distance: height and heading do not count (GPS altitude is the noisiest part of
  // a fix); exactly the tolerance away is still correct.
  const GroundTruth flat = GroundTruth::FromMetricTolerance(
      {{0, 3, 50, 0}, {10, 5, 0, 3.1}}, {PlacePose{0, 0, 0, 0}, PlacePose{10, 0, 0, 0}}, 5);
  EXPECT_EQ(flat.CorrectPlaces(0), (std::vector<int>{0}));
  EXPECT_EQ(flat.CorrectPlaces(1), (std::vector<int>{1}));  // 5 m north of place 1
  EXPECT_THROW(GroundTruth::FromMetricTolerance({}, places, -1), std::invalid_argument);
}

TEST(Evaluation, ComputeMetricsRefusesMismatchedSizes) {
  const GroundTruth t = GroundTruth::FromFrameTolerance(3, 3, 0);
  EXPECT_THROW(ComputeMetrics({0, 1}, {1, 2}, {{0}, {1}}, t), std::invalid_argument);
  const Metrics m = ComputeMetrics({0, 1, 0}, {3, 2, 1}, {{0}, {1}, {0, 2}}, t);
  EXPECT_NEAR(m.recall_at_1, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(m.recall_at_5, 1.0, 1e-12);
  EXPECT_NEAR(m.recall_at_full_precision, 2.0 / 3.0, 1e-12);
  EXPECT_EQ(m.num_queries, 3);
}

// Queries without a true match (off the map): how many there are, and how many of them had
// their match accepted; an accepted match of an on-map query does not count, wrong or not.
TEST(Evaluation, OffMapAcceptancesAreCounted) {
  const GroundTruth t({{0}, {}, {2}, {}, {}});
  std::vector<QueryOutcome> o(5);
  const bool accepted[] = {true, true, true, false, true};
  const int match[] = {0, 1, 5, 3, 4};
  for (size_t q = 0; q < o.size(); ++q) {
    o[q].match = match[q];
    o[q].accepted = accepted[q];
    o[q].confidence = 1.0 + static_cast<double>(q);
    o[q].top_places = {match[q]};
  }
  const Metrics m = ScoreOutcomes(o, t);
  EXPECT_EQ(m.off_map_queries, 3);
  EXPECT_EQ(m.off_map_accepted, 2);  // queries 1 and 4
  // Without what was accepted (ComputeMetrics) the queries are counted, the acceptances not.
  const Metrics n = ComputeMetrics({0, 1, 5, 3, 4}, {1, 2, 3, 4, 5}, {{0}, {1}, {5}, {3}, {4}}, t);
  EXPECT_EQ(n.off_map_queries, 3);
  EXPECT_EQ(n.off_map_accepted, 0);
}

}  // namespace
}  // namespace bsf_vpr
