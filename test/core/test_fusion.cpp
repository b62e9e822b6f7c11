#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/decision.h"
#include "bsf_vpr/core/fusion.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

struct Fixture {
  std::vector<std::vector<float>> d;
  std::vector<SetDistances> views;
  explicit Fixture(int m, int n, uint64_t seed) {
    for (int u = 0; u < m; ++u) d.push_back(testing::RandomDistances(n, seed + u));
    for (const auto& x : d) views.push_back({x.data(), nullptr, n});
  }
};

PlaceBelief Fuse(const std::vector<SetDistances>& v, int n,
                 const Eigen::VectorXd* prior = nullptr) {
  PlaceBelief b;
  std::vector<int> use(v.size());
  std::iota(use.begin(), use.end(), 0);
  FuseBayes(v, use, n, {}, prior, &b);
  Decide(DecisionOptions{}, Evidence{}, &b);
  return b;
}

TEST(Fusion, PosteriorIsNormalisedAndMatchIsItsArgmax) {
  Fixture f(3, 400, 1);
  const PlaceBelief b = Fuse(f.views, 400);
  EXPECT_NEAR(b.log_posterior.array().exp().sum(), 1.0, 1e-9);
  Eigen::Index best;
  b.log_posterior.maxCoeff(&best);
  EXPECT_EQ(b.match, best);
  EXPECT_EQ(b.top_places.front(), b.match);
  EXPECT_EQ(b.top_places.size(), 10u);
}

TEST(Fusion, PosteriorIsInvariantToPermutingPlaces) {
  Fixture f(3, 300, 2);
  const PlaceBelief b = Fuse(f.views, 300);
  std::vector<int> perm(300);
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937_64(5));
  // Permuted set: row k now holds place perm[k].
  std::vector<SetDistances> pv = f.views;
  std::vector<std::vector<float>> pd(3, std::vector<float>(300));
  for (int u = 0; u < 3; ++u) {
    for (int k = 0; k < 300; ++k)
      pd[u][static_cast<size_t>(perm[k])] = f.d[u][static_cast<size_t>(k)];
    pv[u].values = pd[u].data();
  }
  const PlaceBelief p = Fuse(pv, 300);
  EXPECT_EQ(p.match, perm[static_cast<size_t>(b.match)]);
  for (int k = 0; k < 300; ++k) EXPECT_NEAR(p.log_posterior(perm[k]), b.log_posterior(k), 1e-9);
}

TEST(Fusion, EqualsTheProductOfSingleReferenceLikelihoodsTimesThePrior) {
  Fixture f(2, 50, 3);
  Eigen::VectorXd log_prior = testing::RandomMatrix(50, 1, 9).cast<double>().col(0);
  const PlaceBelief b = Fuse(f.views, 50, &log_prior);
  std::vector<double> l0(50), l1(50);
  PlaceMatchLogLikelihood(f.views[0], {}, l0.data());
  PlaceMatchLogLikelihood(f.views[1], {}, l1.data());
  for (int i = 1; i < 50; ++i) {
    const double expected = (l0[i] + l1[i] + log_prior(i)) - (l0[0] + l1[0] + log_prior(0));
    EXPECT_NEAR(b.log_posterior(i) - b.log_posterior(0), expected, 1e-9);
  }
}

TEST(Fusion, ConfidenceIsLogOddsAndStaysOrderedWhenTheMaximumRoundsToOne) {
  Eigen::VectorXd l(4);
  l << 0.0, -50.0, -60.0, -70.0;  // P(best) rounds to exactly 1.0 in double
  Eigen::VectorXd l2(4);
  l2 << 0.0, -80.0, -90.0, -95.0;
  EXPECT_EQ(std::exp(l(0) - std::log(l.array().exp().sum())), 1.0);
  const double c1 = LogOddsOfBest(l, 0), c2 = LogOddsOfBest(l2, 0);
  const double naive = 50.0 - std::log(1 + std::exp(-10.0) + std::exp(-20.0));
  EXPECT_NEAR(c1, naive, 1e-9);
  EXPECT_GT(c2, c1);
  Eigen::VectorXd single(1);
  single << -3.0;
  EXPECT_EQ(LogOddsOfBest(single, 0), INFINITY);
}

TEST(Fusion, PlacesASetDoesNotCoverGetANeutralLikelihood) {
  std::vector<float> a = testing::RandomDistances(10, 4);
  std::vector<float> b = {0.9f, 1.1f, 1.3f};
  std::vector<int> b_places = {0, 1, 2};
  std::vector<SetDistances> v = {{a.data(), nullptr, 10}, {b.data(), b_places.data(), 3}};
  const PlaceBelief fused = Fuse(v, 12);  // places 10, 11 covered by nobody
  std::vector<double> la(10), lb(3);
  PlaceMatchLogLikelihood(v[0], {}, la.data());
  PlaceMatchLogLikelihood(v[1], {}, lb.data());
  EXPECT_NEAR(fused.log_posterior(5) - fused.log_posterior(4), la[5] - la[4], 1e-9);
  EXPECT_NEAR(fused.log_posterior(1) - fused.log_posterior(4), la[1] + lb[1] - la[4], 1e-9);
  EXPECT_NEAR(fused.log_posterior(11) - fused.log_posterior(10), 0.0, 1e-12);
}

// A set covering every place once takes the fast path (no per-set shift); the same set with
// explicit place ids takes the normalised one. Both must give the same belief, and the
// confidence must be the log-odds of the best place.
TEST(Fusion, FastPathForDenseSetsAgreesWithTheGeneralPath) {
  Fixture f(3, 500, 11);
  std::vector<int> ids(500);
  std::iota(ids.begin(), ids.end(), 0);
  std::vector<SetDistances> with_ids = f.views;
  for (SetDistances& v : with_ids) v.place_ids = ids.data();
  const PlaceBelief fast = Fuse(f.views, 500), general = Fuse(with_ids, 500);
  EXPECT_EQ(fast.match, general.match);
  EXPECT_EQ(fast.top_places, general.top_places);
  EXPECT_NEAR(fast.confidence, general.confidence, 1e-9);
  for (int i = 0; i < 500; ++i) ASSERT_NEAR(fast.log_posterior(i), general.log_posterior(i), 1e-9);
  EXPECT_NEAR(fast.confidence, LogOddsOfBest(fast.log_posterior, fast.match), 1e-9);
  // Far apart places: the sum over the others underflows and the rescaled path answers.
  std::vector<float> sharp(500, 2.0f);
  sharp[42] = 0.0f;
  const std::vector<SetDistances> one = {{sharp.data(), nullptr, 500}};
  Eigen::VectorXd prior = Eigen::VectorXd::Constant(500, -2000.0);
  prior(42) = 0;
  const PlaceBelief b = Fuse(one, 500, &prior);
  EXPECT_EQ(b.match, 42);
  EXPECT_TRUE(std::isfinite(b.confidence));
  EXPECT_NEAR(b.confidence, LogOddsOfBest(b.log_posterior, 42), 1e-6);
  EXPECT_GT(b.confidence, 1000);
}

// Large inputs compute the sets' likelihoods on several threads; the belief must be bitwise
// the one a single thread computes.
TEST(Fusion, ParallelLikelihoodsGiveBitwiseTheSameBelief) {
  Fixture f(3, 20000, 21);  // 60000 distances: above the parallel threshold
  const testing::ScopedDistanceThreads threads(1);
  const PlaceBelief one = Fuse(f.views, 20000);
  threads.Set(3);
  const PlaceBelief many = Fuse(f.views, 20000);
  EXPECT_EQ(one.match, many.match);
  EXPECT_EQ(one.confidence, many.confidence);
  EXPECT_TRUE((one.log_posterior.array() == many.log_posterior.array()).all());
}

TEST(Fusion, RefusesABadPrior) {
  Fixture f(1, 20, 8);
  Eigen::VectorXd wrong_size = Eigen::VectorXd::Zero(19);
  EXPECT_THROW(Fuse(f.views, 20, &wrong_size), std::invalid_argument);
  Eigen::VectorXd nan_prior = Eigen::VectorXd::Zero(20);
  nan_prior(3) = NAN;
  EXPECT_THROW(Fuse(f.views, 20, &nan_prior), std::invalid_argument);
  Eigen::VectorXd zero_prior = Eigen::VectorXd::Constant(20, -INFINITY);
  EXPECT_THROW(Fuse(f.views, 20, &zero_prior), std::invalid_argument);
  // A prior that rules out all but place 7 forces the match.
  Eigen::VectorXd point = Eigen::VectorXd::Constant(20, -INFINITY);
  point(7) = 0;
  EXPECT_EQ(Fuse(f.views, 20, &point).match, 7);
}

TEST(Fusion, RefusesPlaceIdsOutsideTheMap) {
  std::vector<float> d = {1.0f, 2.0f};
  std::vector<int> ids = {0, 12};
  const std::vector<SetDistances> v = {{d.data(), ids.data(), 2}};
  PlaceBelief b;
  EXPECT_THROW(FuseBayes(v, {0}, 10, {}, nullptr, &b), std::invalid_argument);
  EXPECT_THROW(FuseMinEnsembleDistance(v, {0}, 10, &b), std::invalid_argument);
}

TEST(Fusion, TopKOrdersByScoreAndBreaksTiesTowardsSmallerIndex) {
  Eigen::VectorXd s(5);
  s << 1.0, 3.0, 3.0, -INFINITY, 2.0;
  EXPECT_EQ(TopK(s, 3), (std::vector<int>{1, 2, 4}));
  EXPECT_EQ(TopK(s, 10), (std::vector<int>{1, 2, 4, 0}));
}

TEST(Fusion, TopKIsTheHeadOfTheFullOrderOnManyTies) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> level(0, 40);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd s(3000);
    for (Eigen::Index i = 0; i < s.size(); ++i) {
      const int v = level(rng);  // few values: long runs of ties; some impossible, some NaN
      s(i) = v == 0 ? -INFINITY : v == 1 ? std::numeric_limits<double>::quiet_NaN() : v;
    }
    std::vector<int> order;
    for (int i = 0; i < s.size(); ++i) {
      if (s(i) > -INFINITY) order.push_back(i);
    }
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return s(a) > s(b); });
    for (int k : {0, 1, 10, 57, 64, 65, 200, 5000}) {  // one pass up to 64, then a sort
      const std::vector<int> expected(order.begin(),
                                      order.begin() + std::min<size_t>(order.size(), k));
      ASSERT_EQ(TopK(s, k), expected) << "trial " << trial << " k " << k;
    }
  }
}

}  // namespace
}  // namespace bsf_vpr
