#include <gtest/gtest.h>

#include <algorithm>

#include "bsf_vpr/core/distances.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

TEST(Distances, EuclideanMatchesNaiveLoopAndIsNotSquared) {
  const RowMatrixXf q = testing::RandomMatrix(7, 33, 1);
  const ReferenceSet set = MakeReferenceSet("a", testing::RandomMatrix(50, 33, 2));
  const RowMatrixXf d = ComputeDistances(DistanceMetric::kEuclidean, q, set);
  ASSERT_EQ(d.rows(), 7);
  ASSERT_EQ(d.cols(), 50);
  for (int i = 0; i < 7; ++i) {
    for (int j = 0; j < 50; ++j) {
      const float naive = (q.row(i) - set.descriptors.row(j)).norm();
      EXPECT_NEAR(d(i, j), naive, 1e-4f * (1 + naive));
    }
  }
}

TEST(Distances, AQueryAloneGetsBitwiseTheSameDistancesAsInABatch) {
  // Online (one query) and offline (batched) evaluation must agree exactly, so that a replay
  // reproduces the offline matches. Odd dimension: rows start at varying alignments.
  const RowMatrixXf q = testing::RandomMatrix(37, 1001, 11);
  const ReferenceSet set = MakeReferenceSet("a", testing::RandomMatrix(53, 1001, 12));
  for (DistanceMetric m : {DistanceMetric::kEuclidean, DistanceMetric::kCosine}) {
    const RowMatrixXf batch = ComputeDistances(m, q, set);
    for (int i = 0; i < q.rows(); ++i) {
      const RowMatrixXf one = ComputeDistances(m, RowMatrixXf(q.row(i)), set);
      for (int j = 0; j < set.size(); ++j) ASSERT_EQ(one(0, j), batch(i, j)) << i << "," << j;
    }
  }
}

TEST(Distances, AnyThreadCountGivesBitwiseTheSameDistances) {
  const RowMatrixXf q = testing::RandomMatrix(9, 777, 21);
  const ReferenceSet set = MakeReferenceSet("a", testing::RandomMatrix(1001, 777, 22));
  const testing::ScopedDistanceThreads guard(1);
  for (DistanceMetric m : {DistanceMetric::kEuclidean, DistanceMetric::kCosine}) {
    guard.Set(1);
    const RowMatrixXf one = ComputeDistances(m, q, set);
    for (int threads : {2, 3, 8}) {
      guard.Set(threads);
      EXPECT_EQ(DistanceThreads(), threads);
      const RowMatrixXf many = ComputeDistances(m, q, set);
      ASSERT_TRUE((many.array() == one.array()).all()) << threads << " threads";
    }
  }
  guard.Set(0);
  EXPECT_GE(DistanceThreads(), 1);
}

// A batch large enough for every part of the batch path: on AVX-512 the lane tiles (32
// queries or more: panels of 12 queries and 32 rows, whole and partial), elsewhere blocks of
// 96 rows and of 32 queries, and the distances made per block of rows: both metrics against
// a straightforward loop.
TEST(Distances, ALargeBatchMatchesNaiveLoopsForBothMetrics) {
  RowMatrixXf q = testing::RandomMatrix(45, 61, 31);
  RowMatrixXf r = testing::RandomMatrix(230, 61, 32);
  r.row(200).setZero();
  const ReferenceSet set = MakeReferenceSet("a", r);
  const testing::ScopedDistanceThreads threads(2);
  const RowMatrixXf euclidean = ComputeDistances(DistanceMetric::kEuclidean, q, set);
  const RowMatrixXf cosine = ComputeDistances(DistanceMetric::kCosine, q, set);
  for (int i = 0; i < q.rows(); ++i) {
    for (int j = 0; j < r.rows(); ++j) {
      const double dot = q.row(i).cast<double>().dot(r.row(j).cast<double>());
      const double nq = q.row(i).cast<double>().norm(), nr = r.row(j).cast<double>().norm();
      const double l2 = (q.row(i).cast<double>() - r.row(j).cast<double>()).norm();
      ASSERT_NEAR(euclidean(i, j), l2, 1e-4 * (1 + l2)) << i << "," << j;
      const double cos = nr > 0 ? std::max(1.0 - dot / (nq * nr), 0.0) : 1.0;
      ASSERT_NEAR(cosine(i, j), cos, 1e-5) << i << "," << j;
    }
  }
}

TEST(Distances, EuclideanOfIdenticalVectorsIsZeroNotNaN) {
  const RowMatrixXf r = testing::RandomMatrix(5, 16, 3, 100.0f);
  const RowMatrixXf d = ComputeDistances(DistanceMetric::kEuclidean, r, MakeReferenceSet("a", r));
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(std::isfinite(d(i, i)));
    EXPECT_GE(d(i, i), 0.0f);
    EXPECT_LT(d(i, i), 0.05f);  // float cancellation at norm ~400
  }
}

TEST(Distances, CosineMatchesNaiveLoopAndHandlesZeroVectors) {
  RowMatrixXf q = testing::RandomMatrix(4, 20, 4);
  q.row(3).setZero();
  RowMatrixXf r = testing::RandomMatrix(9, 20, 5);
  r.row(2).setZero();
  const RowMatrixXf d = ComputeDistances(DistanceMetric::kCosine, q, MakeReferenceSet("a", r));
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 9; ++j) {
      const float nq = q.row(i).norm(), nr = r.row(j).norm();
      const float expected = (nq > 0 && nr > 0) ? 1.0f - q.row(i).dot(r.row(j)) / (nq * nr) : 1.0f;
      EXPECT_NEAR(d(i, j), expected, 1e-5f);
      EXPECT_GE(d(i, j), 0.0f);
    }
  }
}

TEST(Distances, MapVersionGivesOneMatrixPerSetAndRowViews) {
  ReferenceSets map;
  map.Add(MakeReferenceSet("a", testing::RandomMatrix(10, 8, 6)));
  ReferenceSet b;
  b.name = "b";
  b.descriptors = testing::RandomMatrix(3, 8, 7);
  b.place_ids = {9, 2, 5};
  map.Add(b);
  const RowMatrixXf q = testing::RandomMatrix(2, 8, 8);
  const std::vector<RowMatrixXf> all = ComputeDistances(DistanceMetric::kEuclidean, q, map);
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[1].cols(), 3);
  const std::vector<SetDistances> views = QueryRowViews(all, 1, {nullptr, &map.set(1).place_ids()});
  EXPECT_EQ(views[0].count, 10);
  EXPECT_EQ(views[0].PlaceAt(4), 4);
  EXPECT_EQ(views[1].PlaceAt(0), 9);
  EXPECT_FLOAT_EQ(views[1].values[2], all[1](1, 2));
}

TEST(Distances, RefusesDimensionMismatchAndNonFiniteQueries) {
  const ReferenceSet set = MakeReferenceSet("a", testing::RandomMatrix(5, 8, 9));
  try {
    ComputeDistances(DistanceMetric::kEuclidean, testing::RandomMatrix(2, 7, 1), set);
    FAIL() << "expected a dimension error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("dimension 7"), std::string::npos) << e.what();
  }
  RowMatrixXf bad = testing::RandomMatrix(3, 8, 1);
  bad(2, 4) = NAN;
  try {
    ComputeDistances(DistanceMetric::kCosine, bad, set);
    FAIL() << "expected a NaN error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("query descriptor 2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseDistanceMetric("manhattan"), std::invalid_argument);
}

TEST(Distances, SimilaritiesBecomeNonNegativeDistancesKeepingOrder) {
  RowMatrixXf s(1, 3);
  s << 0.9f, -0.2f, 0.5f;
  RowMatrixXf t(1, 3);
  t << 0.1f, 0.2f, 0.3f;
  const float offset = SimilarityOffset({&s, &t});
  EXPECT_FLOAT_EQ(offset, 1.0f);  // cosine-like similarities: d = 1 - s
  SimilaritiesToDistances(offset, &s);
  EXPECT_NEAR(s(0, 0), 0.1f, 1e-6f);
  EXPECT_NEAR(s(0, 1), 1.2f, 1e-6f);
  RowMatrixXf big(1, 2);
  big << 40.0f, 10.0f;
  const float big_offset = SimilarityOffset({&big});
  SimilaritiesToDistances(big_offset, &big);
  EXPECT_FLOAT_EQ(big(0, 0), 0.0f);
  EXPECT_FLOAT_EQ(big(0, 1), 30.0f);
}

}  // namespace
}  // namespace bsf_vpr
