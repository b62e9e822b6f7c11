// EvaluateMethods: the offline evaluation of methods over blocks of queries, in parallel.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"
#include "bsf_vpr/evaluation/synthetic.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

// Stateless methods run their queries on several threads: the outcomes must be exactly the
// sequential ones, and an error in a worker must reach the caller.
TEST(EvaluationRunner, ParallelEvaluationGivesTheSequentialOutcomesAndPassesErrorsOn) {
  SyntheticOptions opt;
  opt.num_places = 120;
  const SyntheticData data = GenerateMultiConditionData(opt);
  std::vector<RowMatrixXf> all;
  EvaluationInput in = testing::ExactEvaluationInput(data, &all);
  const Method bsf = ParseMethod("bsf", in.set_names);
  std::vector<MethodResults> r;
  {
    const testing::ScopedDistanceThreads threads(3);
    r = EvaluateMethods(in, {bsf}, {}, data.truth, {}, 50);
  }
  MethodRunner sequential(bsf, {});
  for (int q = 0; q < in.num_queries; ++q) {
    const PlaceBelief b =
        sequential.Step(QueryRowViews(all, q, {}), in.num_places, nullptr, std::nullopt, true);
    const QueryOutcome& o = r[0].outcomes[static_cast<size_t>(q)];
    ASSERT_EQ(o.match, b.match) << q;
    ASSERT_EQ(o.confidence, b.confidence) << q;
    ASSERT_EQ(o.top_places, b.top_places) << q;
  }
  std::vector<int> outside(static_cast<size_t>(in.num_places));
  std::iota(outside.begin(), outside.end(), 0);
  outside.back() = in.num_places + 5;  // a place id the map does not have
  in.place_ids = {outside, outside, outside};
  EXPECT_THROW(EvaluateMethods(in, {bsf}, {}, data.truth, {}, 50), std::invalid_argument);
}

// A query the camera did not see (a blind frame) is no observation: no match, confidence
// -infinity, and the filter steps over it as the live node does over a dropped frame: every
// seen query's outcome is the one of a run without the unseen queries at all.
TEST(EvaluationRunner, AnUnseenQueryIsNoObservationAndLeavesTheFilterAsItWas) {
  SyntheticOptions opt;
  opt.num_places = 120;
  const SyntheticData data = GenerateMultiConditionData(opt);
  std::vector<RowMatrixXf> all;
  EvaluationInput in = testing::ExactEvaluationInput(data, &all);
  in.unseen.assign(static_cast<size_t>(in.num_queries), false);
  std::vector<int> seen;
  for (int q = 0; q < in.num_queries; ++q) {
    in.unseen[static_cast<size_t>(q)] = q % 7 == 3 || (q >= 40 && q < 60);
    if (!in.unseen[static_cast<size_t>(q)]) seen.push_back(q);
  }
  const std::vector<Method> methods = {ParseMethod("bsf", in.set_names),
                                       ParseMethod("bsf+filter", in.set_names)};
  const std::vector<MethodResults> r = EvaluateMethods(in, methods, {}, data.truth, {}, 32);
  // The same queries with the unseen ones taken out.
  EvaluationInput only_seen = in;
  only_seen.unseen.clear();
  only_seen.num_queries = static_cast<int>(seen.size());
  std::vector<RowMatrixXf> kept;
  for (const RowMatrixXf& d : all) {
    RowMatrixXf k(static_cast<Eigen::Index>(seen.size()), d.cols());
    for (size_t i = 0; i < seen.size(); ++i) k.row(static_cast<Eigen::Index>(i)) = d.row(seen[i]);
    kept.push_back(k);
  }
  only_seen.distances = [&kept](int b, int e, std::vector<RowMatrixXf>* block) {
    block->clear();
    for (const RowMatrixXf& d : kept) block->push_back(d.middleRows(b, e - b));
  };
  GroundTruth truth_seen = GroundTruth::FromFrameTolerance(only_seen.num_queries, in.num_places, 0);
  const std::vector<MethodResults> ref =
      EvaluateMethods(only_seen, methods, {}, truth_seen, {}, 32);
  for (size_t k = 0; k < methods.size(); ++k) {
    size_t i = 0;
    for (int q = 0; q < in.num_queries; ++q) {
      const QueryOutcome& o = r[k].outcomes[static_cast<size_t>(q)];
      if (in.unseen[static_cast<size_t>(q)]) {
        EXPECT_EQ(o.match, -1) << q;
        EXPECT_FALSE(o.accepted) << q;
        EXPECT_EQ(o.confidence, -std::numeric_limits<double>::infinity()) << q;
        continue;
      }
      const QueryOutcome& e = ref[k].outcomes[i++];
      ASSERT_EQ(o.match, e.match) << methods[k].Name() << " " << q;
      ASSERT_EQ(o.confidence, e.confidence) << methods[k].Name() << " " << q;
    }
  }
  in.unseen.pop_back();
  EXPECT_THROW(EvaluateMethods(in, methods, {}, data.truth, {}, 32), std::invalid_argument);
}

// Odometry steps reach each +filter step as the node's odometry does (MethodRunner::Step's
// step_places); NaN is no step (the filter's own).
TEST(EvaluationRunner, OdometryStepsAreTheFiltersSteps) {
  SyntheticOptions opt;
  opt.num_places = 120;
  const SyntheticData data = GenerateMultiConditionData(opt);
  std::vector<RowMatrixXf> all;
  EvaluationInput in = testing::ExactEvaluationInput(data, &all);
  in.odometry_steps.assign(static_cast<size_t>(in.num_queries), 0.0);  // standing still
  in.odometry_steps[0] = std::nan("");
  in.odometry_steps[7] = 3.5;
  const Method filter = ParseMethod("bsf+filter", in.set_names);
  const std::vector<MethodResults> r = EvaluateMethods(in, {filter}, {}, data.truth, {}, 32);
  EvaluationInput without = in;
  without.odometry_steps.clear();
  const std::vector<MethodResults> w = EvaluateMethods(without, {filter}, {}, data.truth, {}, 32);
  MethodRunner sequential(filter, {});
  int differ = 0;
  for (int q = 0; q < in.num_queries; ++q) {
    const double s = in.odometry_steps[static_cast<size_t>(q)];
    const PlaceBelief b =
        sequential.Step(QueryRowViews(all, q, {}), in.num_places, nullptr,
                        std::isfinite(s) ? std::optional<double>(s) : std::nullopt, true);
    const QueryOutcome& o = r[0].outcomes[static_cast<size_t>(q)];
    ASSERT_EQ(o.match, b.match) << q;
    ASSERT_EQ(o.confidence, b.confidence) << q;
    differ += o.confidence != w[0].outcomes[static_cast<size_t>(q)].confidence;
  }
  EXPECT_GT(differ, in.num_queries / 2);  // a robot standing still is not one moving on
  in.odometry_steps.pop_back();
  EXPECT_THROW(EvaluateMethods(in, {filter}, {}, data.truth, {}, 32), std::invalid_argument);
}

// With many places, fusion inside the evaluator's parallel queries runs its own parallel
// step nested in theirs: it must neither deadlock nor change a result.
TEST(EvaluationRunner, NestedParallelFusionInTheEvaluatorMatchesOneThread) {
  const int n = 20000, q = 6;
  std::vector<RowMatrixXf> all;
  for (uint64_t u = 0; u < 3; ++u) {
    all.push_back(testing::RandomMatrix(q, n, 40 + u).cwiseAbs());
  }
  EvaluationInput in;
  in.num_queries = q;
  in.num_places = n;
  in.set_names = {"a", "b", "c"};
  in.distances = [&](int b, int e, std::vector<RowMatrixXf>* block) {
    block->clear();
    for (const RowMatrixXf& d : all) block->push_back(d.middleRows(b, e - b));
  };
  const GroundTruth truth = GroundTruth::FromFrameTolerance(q, n, 2);
  const std::vector<Method> bsf = {ParseMethod("bsf", in.set_names)};
  const testing::ScopedDistanceThreads threads(1);
  const std::vector<MethodResults> one = EvaluateMethods(in, bsf, {}, truth, {}, 4);
  threads.Set(2);
  const std::vector<MethodResults> two = EvaluateMethods(in, bsf, {}, truth, {}, 4);
  for (int k = 0; k < q; ++k) {
    EXPECT_EQ(one[0].outcomes[static_cast<size_t>(k)].match,
              two[0].outcomes[static_cast<size_t>(k)].match);
    EXPECT_EQ(one[0].outcomes[static_cast<size_t>(k)].confidence,
              two[0].outcomes[static_cast<size_t>(k)].confidence);
  }
}

}  // namespace
}  // namespace bsf_vpr
