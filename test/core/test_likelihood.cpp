#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "bsf_vpr/core/likelihood.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

SetDistances View(const std::vector<float>& d) {
  return {d.data(), nullptr, static_cast<int>(d.size())};
}

TEST(Likelihood, RankCountsMatchTheQuadraticIndicatorSum) {
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    const std::vector<float> d =
        testing::RandomDistances(200 + static_cast<int>(seed), seed, seed % 2 == 0);
    std::vector<int> counts(d.size());
    RankCounts(d.data(), static_cast<int>(d.size()), counts.data());
    for (size_t i = 0; i < d.size(); ++i) {
      ASSERT_EQ(counts[i], testing::RankCountOracle(d, i)) << "seed " << seed << " i " << i;
    }
  }
}

// c_k by sorting a copy: the oracle for sizes the quadratic sum cannot reach.
std::vector<int> SortedRankCounts(const std::vector<float>& d) {
  std::vector<float> sorted = d;
  std::sort(sorted.begin(), sorted.end());
  std::vector<int> counts(d.size());
  for (size_t i = 0; i < d.size(); ++i) {
    const auto first = std::lower_bound(sorted.begin(), sorted.end(), d[i]);
    counts[i] = static_cast<int>(sorted.end() - first);
  }
  return counts;
}

TEST(Likelihood, RankCountsAreExactForEveryShapeOfDistances) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> uni(0.5f, 2.0f);
  std::normal_distribution<float> normal(1.0f, 0.1f);
  const auto make = [&](int n, auto&& value) {
    std::vector<float> d(static_cast<size_t>(n));
    for (float& v : d) v = value();
    return d;
  };
  std::vector<std::pair<std::string, std::vector<float>>> cases;
  cases.emplace_back("uniform 100000", make(100000, [&] { return uni(rng); }));
  cases.emplace_back("normal 100000", make(100000, [&] { return normal(rng); }));
  // Within part of one octave (Euclidean distances of random 4096-d rows): the keys share
  // their top 10 bits, and the last radix pass is skipped.
  std::uniform_real_distribution<float> narrow(40.0f, 46.0f);
  cases.emplace_back("narrow 100000", make(100000, [&] { return narrow(rng); }));
  // Few distinct values: long runs of ties, many in one bucket.
  cases.emplace_back("ties", make(50000, [&] { return std::round(uni(rng) * 8.0f) / 8.0f; }));
  // One far value: every other lands in the first bucket, which then holds nearly all.
  std::vector<float> outlier = make(20000, [&] { return uni(rng); });
  outlier[77] = 1e30f;
  cases.emplace_back("one far outlier", outlier);
  std::vector<float> signs = make(5000, [&] { return uni(rng) - 1.25f; });
  signs[1] = -0.0f;
  signs[2] = 0.0f;
  signs[3] = -0.0f;
  cases.emplace_back("negative, -0 and +0", signs);
  std::vector<float> infinite = make(3000, [&] { return uni(rng); });
  infinite[9] = INFINITY;
  infinite[10] = -INFINITY;
  cases.emplace_back("infinities", infinite);
  cases.emplace_back("all equal", std::vector<float>(1000, 0.75f));
  cases.emplace_back("one", std::vector<float>{3.0f});
  cases.emplace_back("none", std::vector<float>{});
  cases.emplace_back("just above insertion size", make(33, [&] { return uni(rng); }));
  for (const auto& [name, d] : cases) {
    std::vector<int> counts(d.size(), -1);
    RankCounts(d.data(), static_cast<int>(d.size()), counts.data());
    const std::vector<int> expected = SortedRankCounts(d);
    for (size_t i = 0; i < d.size(); ++i) {
      ASSERT_EQ(counts[i], expected[i]) << name << " i " << i << " value " << d[i];
    }
  }
}

// The likelihood is defined up to a per-set constant: compare differences between places.
void ExpectMatchesOracle(LikelihoodVariant variant, bool one_sided) {
  for (uint64_t seed = 1; seed <= 10; ++seed) {
    const std::vector<float> d = testing::RandomDistances(300, seed * 7, seed % 3 == 0);
    std::vector<double> ll(d.size());
    PlaceMatchLogLikelihood(View(d), {variant}, ll.data());
    const double oracle0 = testing::LogLikelihoodOracle(d, 0, one_sided);
    for (size_t i = 1; i < d.size(); ++i) {
      const double expected = testing::LogLikelihoodOracle(d, i, one_sided) - oracle0;
      ASSERT_NEAR(ll[i] - ll[0], expected, 1e-6 * (1 + std::abs(expected))) << "i " << i;
    }
  }
}

TEST(Likelihood, TwoSidedIsExactlyThePaper) {
  ExpectMatchesOracle(LikelihoodVariant::kTwoSided, false);
}

TEST(Likelihood, OneSidedClampsTheUpperTail) {
  ExpectMatchesOracle(LikelihoodVariant::kOneSided, true);
}

TEST(Likelihood, OneSidedDoesNotRewardAFarOutlierTwoSidedDoes) {
  // A place far above the others (e.g. a dark frame) has the lowest rank count; only the
  // two-sided Gaussian term makes it the most likely place.
  std::vector<float> d = testing::RandomDistances(500, 3);
  d[10] = 0.3f;    // the true place: closest
  d[20] = 100.0f;  // outlier
  std::vector<double> one(d.size()), two(d.size());
  PlaceMatchLogLikelihood(View(d), {LikelihoodVariant::kOneSided}, one.data());
  PlaceMatchLogLikelihood(View(d), {LikelihoodVariant::kTwoSided}, two.data());
  EXPECT_EQ(std::max_element(one.begin(), one.end()) - one.begin(), 10);
  EXPECT_EQ(std::max_element(two.begin(), two.end()) - two.begin(), 20);
}

TEST(Likelihood, IsNormalisedSoUncoveredPlacesAreNeutral) {
  const std::vector<float> d = testing::RandomDistances(100, 5);
  std::vector<double> ll(d.size());
  PlaceMatchLogLikelihood(View(d), {}, ll.data());
  double mean_exp = 0;
  for (double v : ll) mean_exp += std::exp(v);
  EXPECT_NEAR(mean_exp / static_cast<double>(d.size()), 1.0, 1e-9);
}

TEST(Likelihood, ZeroVarianceGivesFiniteEqualValues) {
  const std::vector<float> d(50, 1.5f);
  for (auto variant : {LikelihoodVariant::kOneSided, LikelihoodVariant::kTwoSided}) {
    std::vector<double> ll(d.size());
    PlaceMatchLogLikelihood(View(d), {variant}, ll.data());
    for (double v : ll) {
      ASSERT_TRUE(std::isfinite(v));
      EXPECT_NEAR(v, 0.0, 1e-12);
    }
  }
  const std::vector<float> one{0.0f};
  double ll = 1;
  PlaceMatchLogLikelihood(View(one), {}, &ll);
  EXPECT_NEAR(ll, 0.0, 1e-12);
}

TEST(Likelihood, ParsesVariantNames) {
  EXPECT_EQ(ParseLikelihoodVariant("one_sided"), LikelihoodVariant::kOneSided);
  EXPECT_EQ(ParseLikelihoodVariant("two_sided"), LikelihoodVariant::kTwoSided);
  EXPECT_THROW(ParseLikelihoodVariant("both"), std::invalid_argument);
}

}  // namespace
}  // namespace bsf_vpr
