// The +filter prior (PredictLogPrior) and the filtered methods over a route.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>

#include "bsf_vpr/core/temporal_filter.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"
#include "bsf_vpr/evaluation/synthetic.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

TEST(TemporalFilter, MovesTheBeliefForwardAndKeepsEveryPlaceReachable) {
  Eigen::VectorXd post = Eigen::VectorXd::Constant(100, -INFINITY);
  post(10) = 0;  // certain of place 10
  TemporalFilterOptions o;
  o.step_mean_places = 2;
  o.step_std_places = 0;
  o.relocalization_probability = 0.05;
  const Eigen::VectorXd prior = PredictLogPrior(post, o);
  EXPECT_NEAR(prior.array().exp().sum(), 1.0, 1e-12);
  EXPECT_NEAR(std::exp(prior(12)), 0.95 + 0.05 / 100, 1e-12);
  EXPECT_NEAR(std::exp(prior(50)), 0.05 / 100, 1e-12);
  EXPECT_TRUE(prior.allFinite());
  // Odometry replaces the mean step; mass past the end of the route is renormalised.
  EXPECT_NEAR(std::exp(PredictLogPrior(post, o, 5.0)(15)), 0.95 + 0.0005, 1e-12);
  post.setConstant(-INFINITY);
  post(99) = 0;
  EXPECT_NEAR(PredictLogPrior(post, o).array().exp().sum(), 1.0, 1e-12);
  o.relocalization_probability = 0;
  EXPECT_THROW(PredictLogPrior(post, o), std::invalid_argument);
}

// An odometry step far beyond the map (a broken odometer) moves all the mass past the end:
// the prior is uniform, with no overflow of the step's places on the way.
TEST(TemporalFilter, AStepBeyondAnyMapGivesAUniformPrior) {
  Eigen::VectorXd post = Eigen::VectorXd::Zero(50);
  post(3) = 1;
  TemporalFilterOptions o;
  for (const double step : {1e6, -1e6, 1e18, -1e300, 1e300}) {
    const Eigen::VectorXd prior = PredictPrior(post, o, step);
    ASSERT_TRUE(prior.allFinite()) << step;
    EXPECT_NEAR(prior.minCoeff(), 1.0 / 50, 1e-15) << step;
    EXPECT_NEAR(prior.maxCoeff(), 1.0 / 50, 1e-15) << step;
  }
}

// The adaptive fusion's step for its hypotheses: PredictPrior's prior times a likelihood, bit
// for bit, and its sum in the kernels' fixed order, on every kernel; with the uniform prior
// where no mass moves onto the route.
TEST(TemporalFilter, PredictPriorTimesIsThePriorTimesTheLikelihood) {
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    for (const int n : {1, 13, 16, 300}) {
      for (const int kind : {0, 1, 2}) {  // a belief; all zero; one NaN (no mass: uniform)
        Eigen::VectorXd post(n), l(n);
        for (int i = 0; i < n; ++i) {
          post(i) = kind == 1 ? 0.0 : 1.0 + std::sin(0.7 * i);
          l(i) = std::exp(std::cos(1.3 * i) * 5);
        }
        if (kind == 2) post(n / 2) = std::numeric_limits<double>::quiet_NaN();
        TemporalFilterOptions o;
        for (const double step : {1.0, 2.5, 1e6}) {  // 1e6: beyond the route, a uniform prior
          const MotionStep m = MotionStepOf(o, step);
          const Eigen::VectorXd want = PredictPrior(post, o, step).cwiseProduct(l);
          Eigen::VectorXd got(n);
          const double sum = PredictPriorTimes(m, post.data(), n, l.data(), got.data());
          double lanes[8] = {};
          for (int i = 0; i < n; ++i) lanes[i % 8] += want(i);
          const double want_sum = ((lanes[0] + lanes[4]) + (lanes[1] + lanes[5])) +
                                  ((lanes[2] + lanes[6]) + (lanes[3] + lanes[7]));
          const std::string at = kernel + " n " + std::to_string(n) + " kind " +
                                 std::to_string(kind) + " step " + std::to_string(step);
          ASSERT_TRUE(want.allFinite()) << at;
          ASSERT_EQ(std::memcmp(got.data(), want.data(), sizeof(double) * n), 0) << at;
          ASSERT_EQ(sum, want_sum) << at;
        }
      }
    }
  }
  SetDistanceKernel("auto");
}

SyntheticData Route(uint64_t seed) {
  return GenerateMultiConditionData(testing::RandomConditionRoute(8, seed));
}

std::vector<MethodResults> EvaluateInOrder(const SyntheticData& d, const std::vector<int>& order,
                                           const std::string& methods, const GroundTruth& truth) {
  EvaluationInput in;
  in.num_queries = static_cast<int>(order.size());
  in.num_places = d.map.num_places();
  in.set_names = d.map.SetNames();
  in.distances = [&](int b, int e, std::vector<RowMatrixXf>* block) {
    RowMatrixXf q(e - b, d.queries.cols());
    for (int k = b; k < e; ++k) q.row(k - b) = d.queries.row(order[static_cast<size_t>(k)]);
    *block = ComputeDistances(DistanceMetric::kEuclidean, q, d.map);
  };
  return EvaluateMethods(in, ParseMethodList(methods, in.set_names), {}, truth, {}, 64);
}

TEST(TemporalFilter, BeatsSingleImageBsfOnARouteWithConditionChanges) {
  for (uint64_t seed : {1u, 2u}) {
    const SyntheticData d = Route(seed);
    std::vector<int> order(400);
    std::iota(order.begin(), order.end(), 0);
    const auto r = EvaluateInOrder(d, order, "bsf,bsf+filter,bsf+seq", d.truth);
    // Seed 1 measured: R@1 bsf 0.61, bsf+filter 0.90, bsf+seq 0.99 (AUC 0.52, 0.90, 0.98).
    EXPECT_GT(r[1].metrics.recall_at_1, r[0].metrics.recall_at_1 + 0.2) << seed;
    EXPECT_GT(r[1].metrics.auc, r[0].metrics.auc) << seed;
    EXPECT_GT(r[2].metrics.recall_at_1, r[0].metrics.recall_at_1 + 0.2) << seed;
  }
}

TEST(TemporalFilter, RecoversFromATeleportWithinABoundedNumberOfQueries) {
  const SyntheticData d = Route(3);
  std::vector<int> order;  // places 0..149, then the robot appears at 300..399
  for (int p = 0; p < 150; ++p) order.push_back(p);
  for (int p = 300; p < 400; ++p) order.push_back(p);
  std::vector<std::vector<int>> correct;
  for (int p : order) correct.push_back({p});
  const auto r = EvaluateInOrder(d, order, "bsf+filter", GroundTruth(correct));
  const auto& out = r[0].outcomes;
  int first_right_after_jump = -1;
  for (size_t k = 150; k < out.size(); ++k) {
    bool right_from_here = true;
    for (size_t j = k; j < std::min(out.size(), k + 20); ++j) {
      right_from_here = right_from_here && out[j].match == order[j];
    }
    if (right_from_here) {
      first_right_after_jump = static_cast<int>(k - 150);
      break;
    }
  }
  ASSERT_GE(first_right_after_jump, 0) << "never recovered";
  EXPECT_LE(first_right_after_jump, 10);
}

}  // namespace
}  // namespace bsf_vpr
