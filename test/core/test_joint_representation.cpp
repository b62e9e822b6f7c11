// The joint representations of the sets (joint_representation.h) against straightforward
// implementations: the mean, the least-squares residual on each place's references, and the
// discriminant's generalised eigenproblem checked by its defining equation.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <chrono>
#include <random>
#include <thread>

#include "bsf_vpr/core/joint_builder.h"
#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// M sets of one route of n places in `dim` dimensions: place p has a direction of its own,
// each set adds a condition offset of its own and noise. Set u covers the places in
// `covered[u]` (all of them if empty).
ReferenceSets Route(int sets, int n, int dim, uint64_t seed,
                   std::vector<std::vector<int>> covered = {}) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> g(0.0f, 1.0f);
  RowMatrixXf place(n, dim);
  for (Eigen::Index i = 0; i < place.size(); ++i) place.data()[i] = g(rng);
  ReferenceSets map;
  for (int u = 0; u < sets; ++u) {
    Eigen::RowVectorXf condition(dim);
    for (int k = 0; k < dim; ++k) condition(k) = 2.0f * g(rng);
    ReferenceSet s;
    s.name = "set" + std::to_string(u);
    std::vector<int> ids = u < static_cast<int>(covered.size()) ? covered[u] : std::vector<int>{};
    if (ids.empty()) {
      for (int p = 0; p < n; ++p) ids.push_back(p);
    }
    s.descriptors.resize(static_cast<Eigen::Index>(ids.size()), dim);
    for (size_t k = 0; k < ids.size(); ++k) {
      for (int j = 0; j < dim; ++j) {
        s.descriptors(static_cast<Eigen::Index>(k), j) =
            place(ids[k], j) + condition(j) + 0.3f * g(rng);
      }
    }
    s.place_ids = ids;
    map.Add(std::move(s));
  }
  return map;
}

std::vector<const StoredReferenceSet*> Sets(const ReferenceSets& map) {
  std::vector<const StoredReferenceSet*> out;
  for (const StoredReferenceSet& s : map.sets()) out.push_back(&s);
  return out;
}

// Every set's rows, normalised, with their places.
void NormalisedRows(const ReferenceSets& map, MatrixXd* rows, std::vector<int>* places) {
  int total = 0;
  for (const StoredReferenceSet& s : map.sets()) total += s.size();
  rows->resize(total, map.dimension());
  int r = 0;
  std::vector<float> buf(static_cast<size_t>(map.dimension()));
  for (const StoredReferenceSet& s : map.sets()) {
    for (int k = 0; k < s.size(); ++k, ++r) {
      s.DecodeRow(k, buf.data());
      VectorXd v = Eigen::Map<Eigen::VectorXf>(buf.data(), map.dimension()).cast<double>();
      rows->row(r) = v.transpose() / v.norm();
      places->push_back(s.place_ids()[static_cast<size_t>(k)]);
    }
  }
}

TEST(JointRepresentation, MeanDescriptorIsTheCosineToThePlacesMean) {
  const ReferenceSets map = Route(3, 30, 16, 1, {{}, {}, {0, 1, 2, 5, 9, 20}});
  const JointRepresentation j =
      JointRepresentation::Build(JointKind::kMeanDescriptor, Sets(map), map.num_places());
  MatrixXd rows;
  std::vector<int> places;
  NormalisedRows(map, &rows, &places);
  const RowMatrixXf q = Route(1, 4, 16, 9).set(0).ToReferenceSet().descriptors * 3.0f;
  const RowMatrixXf d = j.Distances(q);
  ASSERT_EQ(d.rows(), 4);
  ASSERT_EQ(d.cols(), 30);
  for (int p = 0; p < 30; ++p) {
    VectorXd mean = VectorXd::Zero(16);
    for (Eigen::Index r = 0; r < rows.rows(); ++r) {
      if (places[static_cast<size_t>(r)] == p) mean += rows.row(r).transpose();
    }
    for (int i = 0; i < 4; ++i) {
      const VectorXd x = q.row(i).transpose().cast<double>();
      EXPECT_NEAR(d(i, p), 1.0 - x.dot(mean) / (x.norm() * mean.norm()), 1e-5);
    }
  }
}

TEST(JointRepresentation, SubspaceIsTheResidualOfTheBestReconstruction) {
  for (const int dim : {8, 40}) {  // fewer dimensions than references at a place, and more
    const ReferenceSets map = Route(4, 12, dim, 2);
    const JointRepresentation j =
        JointRepresentation::Build(JointKind::kSubspace, Sets(map), map.num_places());
    MatrixXd rows;
    std::vector<int> places;
    NormalisedRows(map, &rows, &places);
    const RowMatrixXf q = Route(1, 5, dim, 11).set(0).ToReferenceSet().descriptors;
    const RowMatrixXf d = j.Distances(q);
    for (int p = 0; p < 12; ++p) {
      std::vector<Eigen::Index> at;
      for (Eigen::Index r = 0; r < rows.rows(); ++r) {
        if (places[static_cast<size_t>(r)] == p) at.push_back(r);
      }
      MatrixXd a(dim, static_cast<Eigen::Index>(at.size()));
      for (size_t k = 0; k < at.size(); ++k)
        a.col(static_cast<Eigen::Index>(k)) = rows.row(at[k]).transpose();
      for (int i = 0; i < 5; ++i) {
        VectorXd x = q.row(i).transpose().cast<double>();
        x /= x.norm();
        const VectorXd c = a.completeOrthogonalDecomposition().solve(x);  // least squares
        EXPECT_NEAR(d(i, p), (x - a * c).norm(), 2e-4) << "dim " << dim << " place " << p;
      }
    }
  }
}

// The discriminant's directions solve S_b w = lambda (S_w + r I) w with w^T (S_w + r I) w = 1,
// for the largest lambdas, r = ridge x trace(S_w) / D; scatters of the normalised rows.
void CheckDiscriminant(const ReferenceSets& map, int dims, double ridge) {
  JointOptions o;
  o.discriminant_dimensions = dims;
  o.discriminant_ridge = ridge;
  const JointRepresentation j =
      JointRepresentation::Build(JointKind::kDiscriminant, Sets(map), map.num_places(), o);
  MatrixXd rows;
  std::vector<int> places;
  NormalisedRows(map, &rows, &places);
  const int dim = map.dimension(), n = map.num_places();
  const VectorXd mu = rows.colwise().mean().transpose();
  MatrixXd means = MatrixXd::Zero(n, dim);
  std::vector<int> count(static_cast<size_t>(n), 0);
  for (Eigen::Index r = 0; r < rows.rows(); ++r) {
    means.row(places[static_cast<size_t>(r)]) += rows.row(r);
    ++count[static_cast<size_t>(places[static_cast<size_t>(r)])];
  }
  for (int p = 0; p < n; ++p) means.row(p) /= count[static_cast<size_t>(p)];
  MatrixXd sw = MatrixXd::Zero(dim, dim), sb = MatrixXd::Zero(dim, dim);
  for (Eigen::Index r = 0; r < rows.rows(); ++r) {
    const VectorXd e = (rows.row(r) - means.row(places[static_cast<size_t>(r)])).transpose();
    sw += e * e.transpose();
  }
  for (int p = 0; p < n; ++p) {
    const VectorXd e = means.row(p).transpose() - mu;
    sb += count[static_cast<size_t>(p)] * e * e.transpose();
  }
  MatrixXd a = sw;
  a.diagonal().array() += ridge * sw.trace() / dim;
  Eigen::GeneralizedSelfAdjointEigenSolver<MatrixXd> reference(sb, a);
  const VectorXd lambdas = reference.eigenvalues().reverse();
  ASSERT_EQ(j.discriminant_dimensions(), std::min({dims, n - 1, dim}));
  for (int k = 0; k < j.discriminant_dimensions(); ++k) {
    const VectorXd w = j.projection().row(k).transpose().cast<double>();
    EXPECT_NEAR(w.dot(a * w), 1.0, 1e-3) << "direction " << k;
    const double lambda = w.dot(sb * w);
    EXPECT_NEAR(lambda, lambdas(k), 1e-3 * lambdas(0)) << "direction " << k;
    EXPECT_LT((sb * w - lambda * a * w).norm(), 1e-3 * lambdas(0) * (a * w).norm())
        << "direction " << k;
  }
  // The places' vectors and the query's distance as documented.
  const RowMatrixXf q = Route(1, 3, dim, 17).set(0).ToReferenceSet().descriptors;
  const RowMatrixXf d = j.Distances(q);
  const MatrixXd w = j.projection().cast<double>();  // d x D
  for (int i = 0; i < 3; ++i) {
    VectorXd x = q.row(i).transpose().cast<double>();
    x /= x.norm();
    const VectorXd z = w * (x - mu);
    for (int p = 0; p < n; ++p) {
      const VectorXd v = w * (means.row(p).transpose() - mu);
      EXPECT_NEAR(d(i, p), 1.0 - z.dot(v) / (z.norm() * v.norm()), 1e-3);
    }
  }
}

TEST(JointRepresentation, DiscriminantSolvesItsGeneralisedEigenproblem) {
  CheckDiscriminant(Route(3, 20, 12, 3), 5, 0.1);   // more references than dimensions
  CheckDiscriminant(Route(3, 20, 12, 4), 64, 1.0);  // all the directions there are (12)
}

TEST(JointRepresentation, DiscriminantWorksInTheReferencesSpan) {
  // 2 x 10 rows in 60 dimensions: the scatters live in the rows' span; there the defining
  // equation holds with the ridge of the span's dimension (checked through the Gram path).
  const ReferenceSets map = Route(2, 10, 60, 5);
  JointOptions o;
  o.discriminant_dimensions = 4;
  const JointRepresentation j =
      JointRepresentation::Build(JointKind::kDiscriminant, Sets(map), map.num_places(), o);
  ASSERT_EQ(j.discriminant_dimensions(), 4);
  MatrixXd rows;
  std::vector<int> places;
  NormalisedRows(map, &rows, &places);
  const MatrixXd c = rows.rowwise() - rows.colwise().mean();
  // Every direction lies in the span of the centred rows.
  const Eigen::CompleteOrthogonalDecomposition<MatrixXd> span(c.transpose());
  for (int k = 0; k < 4; ++k) {
    const VectorXd w = j.projection().row(k).transpose().cast<double>();
    const VectorXd inside = c.transpose() * span.solve(w);
    EXPECT_LT((w - inside).norm(), 1e-4 * w.norm());
  }
  // The query's nearest place by the discriminant is its own on this easy route.
  const RowMatrixXf q = map.set(0).ToReferenceSet().descriptors;
  const RowMatrixXf d = j.Distances(q);
  for (int i = 0; i < 10; ++i) {
    Eigen::Index best;
    d.row(i).minCoeff(&best);
    EXPECT_EQ(best, i);
  }
}

TEST(JointRepresentation, LargeDimensionsGoThroughThePrincipalDirections) {
  // D above kJointPrincipalDirections and more rows than D: the subspace iteration.
  const ReferenceSets map = Route(2, 400, 600, 6);
  const JointRepresentation j =
      JointRepresentation::Build(JointKind::kDiscriminant, Sets(map), map.num_places());
  EXPECT_EQ(j.discriminant_dimensions(), 64);
  const RowMatrixXf q = map.set(1).ToReferenceSet().descriptors.topRows(50);
  const RowMatrixXf d = j.Distances(q);
  int right = 0;
  for (int i = 0; i < 50; ++i) {
    Eigen::Index best;
    d.row(i).minCoeff(&best);
    right += best == i ? 1 : 0;
  }
  EXPECT_GE(right, 48);
  // Deterministic: the same sets, the same bits.
  const JointRepresentation again =
      JointRepresentation::Build(JointKind::kDiscriminant, Sets(map), map.num_places());
  EXPECT_TRUE(again.projection() == j.projection());
}

TEST(JointRepresentation, RefusesSetsThatShareNoPlaceNamingThem) {
  const ReferenceSets one = Route(1, 10, 8, 7);
  try {
    JointRepresentation::Build(JointKind::kDiscriminant, Sets(one), one.num_places());
    FAIL() << "one set was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'set0'"), std::string::npos) << e.what();
  }
  const ReferenceSets apart = Route(2, 10, 8, 8, {{0, 1, 2, 3, 4}, {5, 6, 7, 8, 9}});
  for (const JointKind kind :
       {JointKind::kMeanDescriptor, JointKind::kSubspace, JointKind::kDiscriminant}) {
    try {
      JointRepresentation::Build(kind, Sets(apart), apart.num_places());
      FAIL() << "sets without a shared place were taken";
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("'set0' and 'set1' share no place"), std::string::npos) << what;
    }
  }
  JointOptions bad;
  bad.discriminant_ridge = -1;
  const ReferenceSets map = Route(2, 10, 8, 9);
  EXPECT_THROW(JointRepresentation::Build(JointKind::kDiscriminant, Sets(map), 10, bad),
               std::invalid_argument);
}

TEST(JointRepresentation, AQueryOfZerosIsFarFromEveryPlace) {
  const ReferenceSets map = Route(2, 10, 8, 10);
  for (const JointKind kind :
       {JointKind::kMeanDescriptor, JointKind::kSubspace, JointKind::kDiscriminant}) {
    const JointRepresentation j = JointRepresentation::Build(kind, Sets(map), 10);
    const RowMatrixXf d = j.Distances(RowMatrixXf::Zero(1, 8));
    EXPECT_TRUE(d.allFinite()) << ToString(kind);
    if (kind != JointKind::kDiscriminant) EXPECT_TRUE((d.array() == 1.0f).all()) << ToString(kind);
    EXPECT_THROW(j.Distances(RowMatrixXf::Zero(1, 7)), std::invalid_argument);
  }
}

TEST(JointBuilder, BuildsInTheBackgroundTheLatestRequestWinning) {
  const ReferenceSets map = Route(3, 400, 256, 12);
  std::mutex m;
  std::vector<JointBuilder::Result> results;
  JointBuilder builder([&](JointBuilder::Result r) {
    std::lock_guard<std::mutex> lock(m);
    results.push_back(std::move(r));
  });
  // A snapshot outlives the map it came from: copies share the rows.
  std::vector<StoredReferenceSet> snapshot = map.sets();
  const auto start = std::chrono::steady_clock::now();
  builder.Request(JointKind::kDiscriminant, snapshot, 400, {}, 1);
  // Returns at once, whatever the build takes.
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 0.05);
  for (uint64_t g = 2; g <= 5; ++g)
    builder.Request(JointKind::kMeanDescriptor, snapshot, 400, {}, g);
  builder.Wait();
  EXPECT_FALSE(builder.busy());
  std::unique_lock<std::mutex> lock(m);
  // The first (unless the second replaced it before it started), maybe one more, and the
  // last: never all five.
  ASSERT_GE(results.size(), 1u);
  ASSERT_LE(results.size(), 3u);
  EXPECT_EQ(results.back().generation, 5u);
  EXPECT_EQ(results.back().kind, JointKind::kMeanDescriptor);
  ASSERT_TRUE(results.back().joint);
  EXPECT_EQ(results.back().joint->num_places(), 400);
  // A request that cannot be built says why.
  lock.unlock();  // the result is handed on under it
  builder.Request(JointKind::kDiscriminant, {map.set(0)}, 400, {}, 6);
  builder.Wait();
  lock.lock();
  EXPECT_FALSE(results.back().joint);
  EXPECT_NE(results.back().error.find("'set0'"), std::string::npos) << results.back().error;
}

TEST(JointBuilder, IsDestroyedWhileBuilding) {
  const ReferenceSets map = Route(3, 600, 300, 13);
  bool called = false;
  {
    JointBuilder builder([&](JointBuilder::Result) { called = true; });
    builder.Request(JointKind::kDiscriminant, map.sets(), 600, {}, 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }  // joins: the running build finishes
  SUCCEED() << called;
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

TEST(JointRepresentation, AQueryHasTheSameBitsAloneAndInABlock) {
  // The node decides a query alone, bsf_evaluate in blocks: a replay must match the offline
  // run bit for bit.
  const ReferenceSets map = Route(3, 40, 24, 31);
  const RowMatrixXf queries = Route(1, 17, 24, 32).set(0).ToReferenceSet().descriptors;
  for (const JointKind kind :
       {JointKind::kMeanDescriptor, JointKind::kSubspace, JointKind::kDiscriminant}) {
    const JointRepresentation j = JointRepresentation::Build(kind, Sets(map), 40);
    const RowMatrixXf block = j.Distances(queries);
    for (Eigen::Index i = 0; i < queries.rows(); ++i) {
      const RowMatrixXf alone = j.Distances(queries.row(i));
      EXPECT_TRUE(alone.row(0) == block.row(i)) << ToString(kind) << " query " << i;
    }
  }
}

}  // namespace
}  // namespace bsf_vpr
