#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bsf_vpr/core/pose_estimate.h"

namespace bsf_vpr {
namespace {

// Places every 10 m along x, heading along x.
std::vector<std::optional<PlacePose>> Route(int n) {
  std::vector<std::optional<PlacePose>> poses(n);
  for (int i = 0; i < n; ++i) poses[i] = PlacePose{10.0 * i, 0, 0, 0};
  return poses;
}

PlaceBelief BeliefOf(const std::vector<double>& p, int match) {
  PlaceBelief b;
  b.match = match;
  b.log_posterior.resize(static_cast<int>(p.size()));
  for (size_t i = 0; i < p.size(); ++i) b.log_posterior[static_cast<int>(i)] = std::log(p[i]);
  return b;
}

TEST(PoseEstimate, OnePlaceHoldingTheMassGivesItsPoseAndTheFloor) {
  PoseEstimateOptions o;
  o.min_std_m = 5;
  const auto e = EstimatePose(BeliefOf({1e-9, 1 - 2e-9, 1e-9, 0}, 1), Route(4), false, o);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->mean.x_m, 10.0, 1e-6);
  EXPECT_NEAR(e->covariance(0, 0), 25.0, 1e-4);
  EXPECT_NEAR(e->covariance(1, 1), 25.0, 1e-9);
  EXPECT_EQ(e->places, 1);
}

TEST(PoseEstimate, TheCovarianceGrowsWhenTheBeliefSpreadsOverDistantPlaces) {
  PoseEstimateOptions o;
  o.min_std_m = 1;
  // Half the mass on place 0, half on place 8 (80 m away): mean between, sd 40 m.
  const auto spread =
      EstimatePose(BeliefOf({0.5, 0, 0, 0, 0, 0, 0, 0, 0.5}, 0), Route(9), false, o);
  ASSERT_TRUE(spread);
  EXPECT_NEAR(spread->mean.x_m, 40.0, 1e-9);
  EXPECT_NEAR(spread->covariance(0, 0), 1600.0 + 1.0, 1e-6);
  // Neighbours only: a small spread.
  const auto near = EstimatePose(BeliefOf({0.5, 0.5, 0, 0, 0, 0, 0, 0, 0}, 0), Route(9), false, o);
  ASSERT_TRUE(near);
  EXPECT_NEAR(near->covariance(0, 0), 25.0 + 1.0, 1e-6);
  EXPECT_GT(spread->covariance(0, 0), 10 * near->covariance(0, 0));
}

TEST(PoseEstimate, CentredOnTheMatchTheSpreadIsMeasuredAboutIt) {
  PoseEstimateOptions o;
  o.min_std_m = 0;
  o.min_std_yaw_rad = 0;
  const auto e = EstimatePose(BeliefOf({0.5, 0, 0.5}, 2), Route(3), true, o);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->mean.x_m, 20.0);
  EXPECT_NEAR(e->covariance(0, 0), 0.5 * 400.0, 1e-9);  // place 0 lies 20 m from the match
}

TEST(PoseEstimate, YawIsAveragedOnTheCircle) {
  std::vector<std::optional<PlacePose>> poses = {PlacePose{0, 0, 0, M_PI - 0.1},
                                                 PlacePose{0, 0, 0, -M_PI + 0.1}};
  const auto e = EstimatePose(BeliefOf({0.5, 0.5}, 0), poses, false);
  ASSERT_TRUE(e);
  EXPECT_NEAR(std::abs(e->mean.yaw_rad), M_PI, 1e-9);
  EXPECT_NEAR(e->covariance(2, 2), 0.01 + 0.01, 1e-9);  // 0.1 rad either side, plus the floor
}

TEST(PoseEstimate, DistanceMethodsUseTheMatchAlone) {
  PlaceBelief b;  // no posterior
  b.match = 2;
  const auto e = EstimatePose(b, Route(3), true);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->mean.x_m, 20.0);
  EXPECT_EQ(e->places, 1);
}

TEST(PoseEstimate, NothingWithoutAPoseOrWithANonFiniteOne) {
  auto poses = Route(3);
  poses[1].reset();
  EXPECT_FALSE(EstimatePose(BeliefOf({0, 1, 0}, 1), poses, true));
  // Without a pose at the match, the posterior's places that have one still give a pose.
  EXPECT_FALSE(EstimatePose(BeliefOf({0, 1, 0}, 1), poses, false));
  poses[1] = PlacePose{std::numeric_limits<double>::quiet_NaN(), 0, 0, 0};
  EXPECT_FALSE(EstimatePose(BeliefOf({0, 1, 0}, 1), poses, false));
  EXPECT_FALSE(EstimatePose(BeliefOf({0, 1, 0}, 1), poses, true));
  // A NaN posterior gives nothing but the match's pose.
  PlaceBelief nan = BeliefOf({0.5, 0.5, 0}, 0);
  nan.log_posterior[0] = std::numeric_limits<double>::quiet_NaN();
  nan.log_posterior[1] = std::numeric_limits<double>::quiet_NaN();
  const auto e = EstimatePose(nan, Route(3), false);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->mean.x_m, 0.0);
  EXPECT_FALSE(EstimatePose(BeliefOf({1, 0, 0}, 5), Route(3), false));  // match out of range
}

}  // namespace
}  // namespace bsf_vpr
