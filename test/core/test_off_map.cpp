// The hypothesis "no place of the map": its Bayes factor, its filter and the confidence it
// gives a match (off_map.h), and the runner that applies it (method_runner.h).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/off_map.h"

namespace bsf_vpr {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Log-likelihoods of a query over n places whose non-matching places have an exponential
// upper tail (scale 1), and, if `shown` >= 0, that place standing out by `gap`.
Eigen::VectorXd Query(int n, int shown, double gap, std::mt19937* rng) {
  std::exponential_distribution<double> tail(1.0);
  Eigen::VectorXd ll(n);
  for (int i = 0; i < n; ++i) ll(i) = -5 + tail(*rng);
  if (shown >= 0) ll(shown) = ll.maxCoeff() + gap;
  return ll;
}

TEST(OffMap, ConfidenceIsTheMatchAgainstEveryOtherPlaceAndNone) {
  EXPECT_DOUBLE_EQ(ConfidenceWithOffMap(1.7, -kInf), 1.7);
  // P(match | on) = 1/2, P(off) = 1/2: P(match) = 1/4, log-odds log(1/3).
  EXPECT_NEAR(ConfidenceWithOffMap(0.0, 0.0), std::log(1.0 / 3.0), 1e-12);
  // A certain match among the places: the odds are those of "on".
  EXPECT_NEAR(ConfidenceWithOffMap(kInf, std::log(0.2 / 0.8)), std::log(0.8 / 0.2), 1e-12);
  // Far out in either direction it stays finite and ordered.
  EXPECT_NEAR(ConfidenceWithOffMap(800.0, std::log(1e-3)), std::log(1e3), 1e-9);
  EXPECT_LT(ConfidenceWithOffMap(-800.0, 0.0), -799.0);
  EXPECT_LT(ConfidenceWithOffMap(3.0, 1.0), ConfidenceWithOffMap(3.0, 0.0));
}

TEST(OffMap, BayesFactorFavoursAPlaceThatStandsOutOfTheTail) {
  std::mt19937 rng(3);
  double shown = 0, none = 0;
  for (int t = 0; t < 50; ++t) {
    const Eigen::VectorXd a = Query(400, 123, 8.0, &rng);
    shown += OffMapLogBayesFactor(a.data(), 400, 4.0);
    const Eigen::VectorXd b = Query(400, -1, 0.0, &rng);
    none += OffMapLogBayesFactor(b.data(), 400, 4.0);
  }
  EXPECT_GT(shown / 50, 2.0);
  EXPECT_LT(none / 50, -0.3);
  // Its neighbours do not count as the runner-up: the same place with them raised too.
  Eigen::VectorXd c = Query(400, 200, 8.0, &rng);
  const double alone = OffMapLogBayesFactor(c.data(), 400, 4.0);
  c(199) = c(201) = c(200) - 0.1;
  EXPECT_NEAR(OffMapLogBayesFactor(c.data(), 400, 4.0), alone, 0.5);
  // Too few peaks to know the tail: no evidence. -inf places are no peaks.
  const Eigen::VectorXd few = Query(10, 3, 5.0, &rng);  // at most 3 peaks 4 apart
  EXPECT_EQ(OffMapLogBayesFactor(few.data(), 10, 4.0), 0.0);
  Eigen::VectorXd gone = Eigen::VectorXd::Constant(400, -kInf);
  gone(5) = 0;
  EXPECT_EQ(OffMapLogBayesFactor(gone.data(), 400, 4.0), 0.0);
}

TEST(OffMap, TrackerLeavesTheMapPastItsEndAndComesBack) {
  std::mt19937 rng(7);
  const int n = 200;
  OffMapOptions options;
  TemporalFilterOptions filter;
  OffMapTracker tracker;
  double log_odds = 0;
  for (int t = 0; t < n; ++t) {  // along the map, each place shown
    log_odds = tracker.Update(Query(n, t, 6.0, &rng), options, filter, std::nullopt, true);
    if (t >= 10) ASSERT_LT(log_odds, std::log(0.01)) << "query " << t;
  }
  int off_after = -1;
  for (int t = 0; t < 30; ++t) {  // past its end: no place shown
    log_odds = tracker.Update(Query(n, -1, 0.0, &rng), options, filter, std::nullopt, true);
    if (off_after < 0 && log_odds > std::log(0.99 / 0.01)) off_after = t;
  }
  EXPECT_GE(off_after, 0);
  EXPECT_LE(off_after, 5);
  // A query the tracker may not keep leaves it as it was.
  const Eigen::VectorXd q = Query(n, -1, 0.0, &rng);
  const double what_if = tracker.Update(q, options, filter, std::nullopt, false);
  EXPECT_EQ(tracker.Update(q, options, filter, std::nullopt, true), what_if);
  // Back on the map: a run of shown places brings it back.
  for (int t = 51; t < 70; ++t) {
    log_odds = tracker.Update(Query(n, t, 6.0, &rng), options, filter, std::nullopt, true);
  }
  EXPECT_LT(log_odds, std::log(0.01));
}

TEST(OffMap, RunnerWithoutItGivesThePapersBelief) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.5f, 1.5f);
  const int n = 120;
  std::vector<std::vector<float>> values(2, std::vector<float>(n));
  MethodOptions off;
  off.off_map.enabled = false;
  MethodOptions on;
  const std::vector<std::string> names{"a", "b"};
  for (const char* name : {"bayes_full", "bayes:a+filter", "bsf+seq"}) {
    const Method m = ParseMethod(name, names);
    MethodRunner with(m, on), without(m, off);
    for (int t = 0; t < 30; ++t) {
      std::vector<SetDistances> sets(2);
      for (int s = 0; s < 2; ++s) {
        for (float& v : values[static_cast<size_t>(s)]) v = u(rng);
        values[static_cast<size_t>(s)][static_cast<size_t>(t)] = 0.1f;
        sets[static_cast<size_t>(s)].values = values[static_cast<size_t>(s)].data();
        sets[static_cast<size_t>(s)].count = n;
      }
      const PlaceBelief a = with.Step(sets, n, nullptr, std::nullopt, true);
      const PlaceBelief b = without.Step(sets, n, nullptr, std::nullopt, true);
      const PlaceBelief paper = m.sequence || m.temporal_filter || m.kind == MethodKind::kBsf
                                    ? b
                                    : RunMethod(m, sets, n, off);
      EXPECT_EQ(b.confidence, paper.confidence) << name;
      EXPECT_EQ(b.off_map_probability, 0.0);
      EXPECT_EQ(a.match, b.match) << name;
      EXPECT_GT(a.off_map_probability, 0.0) << name;
      EXPECT_LE(a.confidence, b.confidence) << name;
      if (t >= 10) EXPECT_LT(a.off_map_probability, 0.05) << name << " query " << t;
    }
  }
}

TEST(OffMap, OptionsAreChecked) {
  OffMapOptions o;
  o.leave_probability = 1.5;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = OffMapOptions();
  o.match_excess = 0.5;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace bsf_vpr
