#include <gtest/gtest.h>

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
