#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

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
  EXPECT_NEAR(e->covariance(1, 1), 25.0, 1e-6);
  EXPECT_EQ(e->places, 1);
  EXPECT_NEAR(e->wrong_probability, 2e-9, 1e-12);
}

TEST(PoseEstimate, TheMeanAndCovarianceAreTheMatchsNeighbourhoodsAndTheRestIsTheChanceOfAnError) {
  PoseEstimateOptions o;
  o.min_std_m = 1;
  o.neighbourhood_m = 15;
  // Half the mass on place 0, half on place 8 (80 m away): the mean stays at the match (the
  // mean of the whole belief, 40 m, is where the robot is not); the other mode is the
  // chance of an error (wrong_probability), not a wider covariance.
  const auto spread =
      EstimatePose(BeliefOf({0.5, 0, 0, 0, 0, 0, 0, 0, 0.5}, 0), Route(9), false, o);
  ASSERT_TRUE(spread);
  EXPECT_NEAR(spread->mean.x_m, 0.0, 1e-9);
  EXPECT_NEAR(spread->covariance(0, 0), 1.0, 1e-6);
  EXPECT_NEAR(spread->wrong_probability, 0.5, 1e-12);
  // Neighbours only: their mean and spread.
  const auto near = EstimatePose(BeliefOf({0.5, 0.5, 0, 0, 0, 0, 0, 0, 0}, 0), Route(9), false, o);
  ASSERT_TRUE(near);
  EXPECT_NEAR(near->mean.x_m, 5.0, 1e-9);
  EXPECT_NEAR(near->covariance(0, 0), 25.0 + 1.0, 1e-6);
  EXPECT_EQ(near->places, 2);
}

TEST(PoseEstimate, TheChanceOfBeingOffTheMapIsTheChanceOfAnError) {
  PoseEstimateOptions o;
  o.min_std_m = 2;
  PlaceBelief b = BeliefOf({0, 1, 0}, 1);
  b.off_map_probability = 0.1;
  const auto e = EstimatePose(b, Route(3), false, o);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->mean.x_m, 10.0, 1e-12);
  EXPECT_NEAR(e->covariance(0, 0), 4.0, 1e-9);
  EXPECT_NEAR(e->covariance(1, 1), 4.0, 1e-9);
  EXPECT_NEAR(e->wrong_probability, 0.1, 1e-12);
}

// The consistency test a localiser's filter relies on: where the belief is right about where
// the robot is and the neighbourhood holds it (the true place drawn from the posterior
// within the neighbourhood, within the place's extent by the floor), the normalised
// estimation error squared of the estimate, e' P^-1 e, averages its dimension (3). Drawn
// from the whole belief instead (a far mode, off the map), the errors are far larger: that
// chance is wrong_probability, which the same draw matches.
TEST(PoseEstimate, ErrorsAreOfTheSizeTheCovarianceClaims) {
  const int n = 60;
  std::vector<std::optional<PlacePose>> poses(n);
  // An arc of radius 100 m turning by 135 degrees, heading along it (yaw differences stay
  // clear of +-pi, where a linear covariance of yaw cannot hold).
  for (int i = 0; i < n; ++i) {
    const double a = 0.75 * M_PI * i / n;
    poses[i] = PlacePose{100 * std::cos(a), 100 * std::sin(a), 0, a + M_PI / 2};
  }
  PoseEstimateOptions o;
  o.neighbourhood_m = 25;
  o.min_std_m = 3;
  o.min_std_yaw_rad = 0.1;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  double nees = 0, wrong = 0, claimed_wrong = 0;
  const int trials = 20000;
  for (int t = 0; t < trials; ++t) {
    // A belief: a mode of a few places, and a second, smaller one elsewhere.
    std::vector<double> p(n, 1e-6);
    const int a = static_cast<int>(u(rng) * n), b = static_cast<int>(u(rng) * n);
    for (int k = -2; k <= 2; ++k)
      p[std::clamp(a + k, 0, n - 1)] += std::exp(-0.5 * k * k) * (1 + u(rng));
    p[b] += 0.3 * u(rng);
    double total = 0;
    for (double v : p) total += v;
    for (double& v : p) v /= total;
    PlaceBelief belief = BeliefOf(p, a);
    belief.off_map_probability = 0.05 * u(rng);
    const auto e = EstimatePose(belief, poses, false, o);
    ASSERT_TRUE(e);
    // Where the robot is, drawn as the belief says; the NEES given the neighbourhood.
    claimed_wrong += e->wrong_probability;
    int place = 0;
    bool off = u(rng) < belief.off_map_probability;
    if (off) {
      place = static_cast<int>(u(rng) * n);
    } else {
      double r = u(rng);
      while (place < n - 1 && (r -= p[place]) > 0) ++place;
    }
    const bool near = !off && std::hypot(poses[place]->x_m - poses[a]->x_m,
                                         poses[place]->y_m - poses[a]->y_m) <= o.neighbourhood_m;
    if (!near) {
      ++wrong;
      --t;  // a draw where the neighbourhood does not hold the robot: counted, not scored
      if (wrong > trials) break;
      continue;
    }
    const PlacePose& truth = *poses[place];
    const Eigen::Vector3d err(
        truth.x_m + o.min_std_m * g(rng) - e->mean.x_m,
        truth.y_m + o.min_std_m * g(rng) - e->mean.y_m,
        std::remainder(truth.yaw_rad + o.min_std_yaw_rad * g(rng) - e->mean.yaw_rad, 2 * M_PI));
    nees += err.dot(e->covariance.ldlt().solve(err));
  }
  EXPECT_NEAR(nees / trials, 3.0, 0.3);
  EXPECT_NEAR(wrong / (trials + wrong), claimed_wrong / (trials + wrong), 0.01);
}

TEST(PoseEstimate, CentredOnTheMatchTheSpreadIsMeasuredAboutIt) {
  PoseEstimateOptions o;
  o.min_std_m = 0;
  o.min_std_yaw_rad = 0;
  o.neighbourhood_m = 25;
  const auto e = EstimatePose(BeliefOf({0.5, 0, 0.5}, 2), Route(3), true, o);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->mean.x_m, 20.0);
  EXPECT_NEAR(e->covariance(0, 0), 0.5 * 400.0, 1e-9);  // place 0 lies 20 m from the match
}

TEST(PoseEstimate, YawIsAveragedOnTheCircle) {
  std::vector<std::optional<PlacePose>> poses = {PlacePose{0, 0, 0, M_PI - 0.1},
                                                 PlacePose{0, 0, 0, -M_PI + 0.1}};
  PoseEstimateOptions o;
  o.neighbourhood_m = 1;
  const auto e = EstimatePose(BeliefOf({0.5, 0.5}, 0), poses, false, o);
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
  // Without a pose at the match there is no neighbourhood to give one.
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
