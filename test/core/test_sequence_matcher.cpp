// SequenceMatcher (causal SeqSLAM-style sequence costs) and the +seq methods' confidence.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/sequence_matcher.h"

namespace bsf_vpr {
namespace {

// The sequence cost written out: min over v of the mean over in-range k.
double SequenceOracle(const std::vector<Eigen::VectorXd>& newest_first, Eigen::Index i,
                      const SequenceOptions& o) {
  double best = INFINITY;
  const int steps = static_cast<int>((o.max_velocity - o.min_velocity) / o.velocity_step + 1e-9);
  for (int s = 0; s <= steps; ++s) {
    const double v = o.min_velocity + s * o.velocity_step;  // the grid, not a running sum
    double sum = 0;
    int used = 0;
    for (size_t k = 0; k < newest_first.size(); ++k) {
      const long p = std::lround(static_cast<double>(i) - v * static_cast<double>(k));
      if (p < 0 || p >= newest_first[k].size()) continue;
      sum += newest_first[k](p);
      ++used;
    }
    best = std::min(best, sum / used);
  }
  return best;
}

TEST(SequenceMatcher, MatchesTheBruteForceFormula) {
  SequenceOptions o;
  o.length = 4;
  o.standardize = false;
  SequenceMatcher m(o);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> uni(0, 1);
  std::vector<Eigen::VectorXd> history;  // newest first
  for (int t = 0; t < 9; ++t) {
    Eigen::VectorXd c(60);
    for (Eigen::Index i = 0; i < c.size(); ++i) c(i) = uni(rng);
    history.insert(history.begin(), c);
    if (history.size() > 4) history.pop_back();
    const Eigen::VectorXd got = m.Push(c);
    for (Eigen::Index i = 0; i < c.size(); ++i) {
      ASSERT_NEAR(got(i), SequenceOracle(history, i, o), 1e-12) << "t " << t << " i " << i;
    }
  }
  EXPECT_EQ(m.queries(), 4);
  EXPECT_THROW(m.Push(Eigen::VectorXd::Zero(59)), std::invalid_argument);
}

TEST(SequenceMatcher, RecoversATraversalThatSingleQueriesGetWrong) {
  // The true place advances one per query; each single query's costs are noisy enough that
  // its own argmin is often wrong.
  SequenceMatcher m;  // L = 5
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 1);
  int single = 0, sequence = 0;
  for (int t = 0; t < 200; ++t) {
    Eigen::VectorXd c(300);
    for (Eigen::Index i = 0; i < c.size(); ++i) c(i) = noise(rng);
    c(50 + t) -= 2.5;
    Eigen::Index a, b;
    c.minCoeff(&a);
    m.Push(c).minCoeff(&b);
    if (t >= 4) {
      single += a == 50 + t;
      sequence += b == 50 + t;
    }
  }
  EXPECT_LT(single, 120);
  EXPECT_GT(sequence, 185);
}

TEST(SequenceMatcher, OptionsAreChecked) {
  SequenceOptions o;
  o.length = 0;
  EXPECT_THROW(SequenceMatcher{o}, std::invalid_argument);
  o = {};
  o.max_velocity = 0.5;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  // An unbounded search is refused before any int conversion (1e-4 took 7 s per query;
  // a huge ratio overflowed an int).
  o = {};
  o.velocity_step = 1e-4;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = {};
  o.max_velocity = 1e300;
  o.velocity_step = 1e-300;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = {};
  o.length = 1000000;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = {};
  o.use_partial_sequences = false;
  SequenceMatcher m(o);
  const Eigen::VectorXd c = Eigen::VectorXd::LinSpaced(10, 0, 9);
  EXPECT_TRUE(m.Push(c).isApprox(m.Push(c)));  // fewer than L queries: the query's own costs
}

TEST(SequenceMatcher, MatchLogOddsIsScaleFreeAndRewardsAClearerBest) {
  std::mt19937_64 rng(8);
  std::normal_distribution<double> noise(0, 1);
  Eigen::VectorXd c(500);
  for (Eigen::Index i = 0; i < c.size(); ++i) c(i) = noise(rng);
  c(100) = -3.0;
  const double base = SequenceMatchLogOdds(c, 100);
  // The same costs in other units and offsets: the same confidence (comparable across
  // queries whatever the base method's scale).
  EXPECT_NEAR(SequenceMatchLogOdds(7.5 * c.array() + 40.0, 100), base, 1e-9);
  c(100) = -6.0;
  const double clearer = SequenceMatchLogOdds(c, 100);
  EXPECT_GT(clearer, base);
  EXPECT_GT(clearer, std::log(0.99 / 0.01));  // six standard deviations among 500 places
  c(100) = -2.0;                              // no better than chance among 500 places
  EXPECT_LT(SequenceMatchLogOdds(c, 100), 0.0);
  c(100) = -60.0;  // Q(z) underflows: still finite and ordered
  EXPECT_TRUE(std::isfinite(SequenceMatchLogOdds(c, 100)));
  EXPECT_GT(SequenceMatchLogOdds(c, 100), clearer);
  c(3) = INFINITY;
  EXPECT_EQ(SequenceMatchLogOdds(c, 3), -INFINITY);
}

TEST(SequenceMatcher, SeqMethodsAreGatedByTheThreshold) {
  // Pure noise: whatever the base method, a +seq match must not be accepted at h = 0.99
  // (it used to be accepted always: 1500 of 1500 in a replay, 668 of them wrong).
  const std::vector<std::string> names = {"a", "b"};
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<float> u(0.5f, 1.5f);
  MethodOptions o;
  o.decision.threshold = Threshold{Threshold::Kind::kProbability, 0.99};
  for (const std::string name : {"bsf+seq", "nn:a+seq", "med+seq", "bsf+filter+seq"}) {
    MethodRunner runner(ParseMethod(name, names), o);
    int accepted_noise = 0, accepted_route = 0;
    for (int t = 0; t < 60; ++t) {
      std::vector<std::vector<float>> d(2, std::vector<float>(400));
      for (auto& set : d) {
        for (float& x : set) x = u(rng);
        if (t >= 30) set[static_cast<size_t>(100 + t)] = 0.05f;  // then a clear route
      }
      const std::vector<SetDistances> v = {{d[0].data(), nullptr, 400},
                                           {d[1].data(), nullptr, 400}};
      const PlaceBelief b = runner.Step(v, 400, nullptr, std::nullopt, true);
      EXPECT_TRUE(std::isfinite(b.confidence) || !b.accepted);
      if (t < 30) accepted_noise += b.accepted;
      if (t >= 40) accepted_route += b.accepted && b.match == 100 + t;
    }
    EXPECT_LE(accepted_noise, 1) << name;
    EXPECT_GE(accepted_route, 18) << name;
  }
}

}  // namespace
}  // namespace bsf_vpr
