// The decision from a place layout and explicit distances, with no descriptors in the
// process: the combiner of a sharded map decides this way.
#include <gtest/gtest.h>

#include <memory>
#include <optional>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/place_decider.h"
#include "bsf_vpr/core/recognizer_options.h"
#include "bsf_vpr/core/sharding.h"
#include "bsf_vpr/evaluation/synthetic.h"

namespace bsf_vpr {
namespace {

SyntheticData Data() {
  SyntheticOptions opt;
  opt.num_places = 90;
  opt.dimension = 12;
  opt.set_noise = {0.3, 0.35, 0.3};
  opt.condition_strength = 0.5;
  opt.query_noise = 0.3;
  return GenerateMultiConditionData(opt);
}

// A map's parts, as LocalMap holds them: the sets, their distances to a query and to the
// sets' discriminant.
struct Whole {
  explicit Whole(const ReferenceSets& map) : map(map) {
    std::vector<const StoredReferenceSet*> sets;
    for (const StoredReferenceSet& s : map.sets()) sets.push_back(&s);
    joint = std::make_unique<JointRepresentation>(
        JointRepresentation::Build(JointKind::kDiscriminant, sets, map.num_places()));
  }
  std::vector<RowMatrixXf> Distances(const Eigen::VectorXf& query) const {
    return ComputeDistances(DistanceMetric::kEuclidean, query.transpose(), map);
  }
  std::optional<QueryDistances::Joint> JointDistances(const Eigen::VectorXf& query) const {
    return QueryDistances::Joint{JointKind::kDiscriminant, 1, joint->Distances(query.transpose())};
  }
  const ReferenceSets& map;
  std::unique_ptr<JointRepresentation> joint;
};

// The layout of `map` rebuilt from its sets' places alone, as a combiner builds it.
PlaceLayout LayoutAlone(const ReferenceSets& map) {
  PlaceLayout layout;
  for (const SetLayout& s : map.layout().sets()) layout.Add(s);
  return layout;
}

TEST(PlaceDecider, AnAbsentSetIsLeftOutAndNamed) {
  const SyntheticData data = Data();
  const Whole whole(data.map);
  PlaceDecider decider;
  decider.OnLayoutChanged(whole.map.layout());
  const Eigen::VectorXf query = data.queries.row(3).transpose();
  QueryDistances d = QueryDistances::AllPresent(whole.Distances(query));
  QueryDistances without(d.num_sets());
  without.Set(0, d.of(0));
  without.Set(2, d.of(2));
  EXPECT_EQ(without.Absent(), std::vector<int>{1});
  EXPECT_THROW(without.of(1), std::logic_error);
  const Recognition r = decider.Decide(whole.map.layout(), without, false);
  EXPECT_EQ(r.missing_sets, std::vector<int>{1});
  EXPECT_EQ(r.belief.set_weights.at(1), 0.0);
  EXPECT_THROW(decider.Decide(whole.map.layout(), QueryDistances(3), false),
               std::invalid_argument);  // every set absent
  EXPECT_THROW(decider.Decide(whole.map.layout(), QueryDistances(2), false),
               std::invalid_argument);  // not the layout's sets
  QueryDistances bad = d;
  RowMatrixXf nan = d.of(0);
  nan(0, 4) = NAN;
  bad.Set(0, nan);
  EXPECT_THROW(decider.Decide(whole.map.layout(), bad, true), std::invalid_argument);
}

TEST(PlaceDecider, AMethodNamingASetIsResolvedAgainstEachLayout) {
  const SyntheticData data = Data();
  PlaceLayout layout = LayoutAlone(data.map);
  PlaceDecider decider("nn:" + data.map.set(2).name());
  decider.OnLayoutChanged(layout);
  EXPECT_EQ(decider.method().set_index, 2);
  EXPECT_THROW(decider.CheckRemovable(data.map.set(2).name()), std::invalid_argument);
  EXPECT_NO_THROW(decider.CheckRemovable(data.map.set(0).name()));
  layout.Remove(data.map.set(0).name());
  decider.OnLayoutChanged(layout);
  EXPECT_EQ(decider.method().set_index, 1);
  layout.Remove(data.map.set(2).name());
  decider.OnLayoutChanged(layout);  // never throws; the next decision says why
  QueryDistances d(1);
  d.Set(0, RowMatrixXf::Ones(1, layout.set(0).size()));
  EXPECT_THROW(decider.Decide(layout, d, false), std::invalid_argument);
  EXPECT_THROW(decider.SetMethod("nn:gone", {}, layout), std::invalid_argument);
}

TEST(PlaceLayout, RefusesWhatCannotShareThePlaceIndexAndStaysAsItWas) {
  PlaceLayout layout;
  SetLayout a;
  a.name = "a";
  a.place_ids = {0, 1, 2};
  a.poses = {{0, 0, 0, 0}, {10, 0, 0, 0}, {20, 0, 0, 0}};
  a.dimension = 8;
  layout.Add(a);
  EXPECT_EQ(layout.num_places(), 3);
  ASSERT_TRUE(layout.MedianPlaceSpacing());
  EXPECT_DOUBLE_EQ(*layout.MedianPlaceSpacing(), 10.0);
  SetLayout b = a;
  EXPECT_THROW(layout.Add(b), std::invalid_argument);  // name taken
  b.name = "";
  EXPECT_THROW(layout.Add(b), std::invalid_argument);  // no name
  b.name = "b";
  b.dimension = 0;
  EXPECT_THROW(layout.Add(b), std::invalid_argument);  // no descriptors to compare
  b.name = "b";
  b.dimension = 9;
  EXPECT_THROW(layout.Add(b), std::invalid_argument);  // dimension
  b.dimension = 8;
  b.poses[1].x_m = 200;
  EXPECT_THROW(layout.Add(b), std::invalid_argument);  // place 1 is elsewhere
  b.poses[1].x_m = 10;
  b.place_ids = {0, 0, 5};
  EXPECT_THROW(layout.Add(b), std::invalid_argument);  // two rows for place 0
  EXPECT_EQ(layout.num_sets(), 1);
  EXPECT_EQ(layout.num_places(), 3);
  b.place_ids = {3, 4, 5};
  b.poses.clear();
  layout.Add(b);
  EXPECT_EQ(layout.num_places(), 6);
  EXPECT_FALSE(layout.PoseOf(4));
  EXPECT_TRUE(layout.Remove("a"));
  EXPECT_EQ(layout.num_places(), 6);
  EXPECT_FALSE(layout.PoseOf(0));
  EXPECT_FALSE(layout.Remove("a"));
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

TEST(PlaceDecider, TakesTheJointDistancesAndStartsAgainWithANewBuild) {
  const SyntheticData data = Data();
  RecognizerOptions options;
  const Whole whole(data.map);
  const PlaceLayout layout = LayoutAlone(whole.map);
  const auto distances = [&](int q, uint64_t build) {
    const Eigen::VectorXf query = data.queries.row(q).transpose();
    QueryDistances d = QueryDistances::AllPresent(whole.Distances(query));
    std::optional<QueryDistances::Joint> j = whole.JointDistances(query);
    EXPECT_TRUE(j.has_value());
    j->build = build;
    d.SetJoint(std::move(*j));
    return d;
  };
  // discriminant needs the joint distances; a wrong shape is refused, the state untouched.
  PlaceDecider only("discriminant", options.method_options);
  only.OnLayoutChanged(layout);
  QueryDistances bare = distances(0, 1);
  QueryDistances no_joint =
      QueryDistances::AllPresent(whole.Distances(data.queries.row(0).transpose()));
  EXPECT_THROW(only.Decide(layout, no_joint, true), std::invalid_argument);
  QueryDistances::Joint wrong = *bare.joint();
  wrong.distances = RowMatrixXf(wrong.distances.leftCols(10));  // a copy: no aliasing
  no_joint.SetJoint(wrong);
  EXPECT_THROW(only.Decide(layout, no_joint, true), std::invalid_argument);
  EXPECT_GE(only.Decide(layout, bare, true).belief.match, 0);
  // bsf with its joint hypothesis: a new build starts the carried state again, so the
  // decisions after it are those of a decider that starts there.
  PlaceDecider running("bsf+filter", options.method_options);
  running.OnLayoutChanged(layout);
  for (int q = 0; q < 15; ++q) running.Decide(layout, distances(q, 1), true);
  PlaceDecider fresh("bsf+filter", options.method_options);
  fresh.OnLayoutChanged(layout);
  for (int q = 15; q < 25; ++q) {
    const Recognition a = running.Decide(layout, distances(q, 2), true);
    const Recognition b = fresh.Decide(layout, distances(q, 2), true);
    ASSERT_EQ(a.belief.confidence, b.belief.confidence) << "query " << q;
    EXPECT_GT(a.belief.joint_weight, 0.0);
  }
}

// The fingerprint tells sets apart by what distances read: same file, same fingerprint;
// another row, name, pose or precision, another fingerprint.
TEST(Sharding, SetFingerprintFollowsWhatTheSetHolds) {
  const SyntheticData data = Data();
  const ReferenceSet c0 = data.map.set(0).ToReferenceSet();
  const auto fingerprint = [](const ReferenceSet& set, StoragePrecision precision) {
    ReferenceSets map;
    map.SetStoragePrecision(precision);
    map.Add(set);
    return SetFingerprint(map.set(0));
  };
  const uint64_t base = fingerprint(c0, StoragePrecision::kFloat32);
  EXPECT_EQ(base, fingerprint(c0, StoragePrecision::kFloat32));
  EXPECT_EQ(base, SetFingerprint(data.map.set(0)));
  EXPECT_NE(base, fingerprint(c0, StoragePrecision::kInt8));
  ReferenceSet changed = c0;
  changed.descriptors(3, 2) += 1e-3f;
  EXPECT_NE(base, fingerprint(changed, StoragePrecision::kFloat32));
  changed = c0;
  changed.name = "c0b";
  EXPECT_NE(base, fingerprint(changed, StoragePrecision::kFloat32));
  changed = c0;
  changed.place_ids.back() += 1000;
  EXPECT_NE(base, fingerprint(changed, StoragePrecision::kFloat32));
  changed = c0;
  changed.poses.assign(c0.place_ids.size(), PlacePose{});
  EXPECT_NE(base, fingerprint(changed, StoragePrecision::kFloat32));
  // The map's layout of a set keeps its places, not its descriptors.
  const SetLayout& layout = data.map.layout().set(0);
  EXPECT_EQ(layout.place_ids, c0.place_ids);
  EXPECT_EQ(layout.size(), c0.size());
  EXPECT_EQ(layout.dimension, c0.dimension());
}

}  // namespace
}  // namespace bsf_vpr
