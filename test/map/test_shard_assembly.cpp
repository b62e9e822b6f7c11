#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>

#include "bsf_vpr/map/shard_assembly.h"

namespace bsf_vpr {
namespace {

ShardSets::Set OneSet(const std::string& name, int places, uint64_t fingerprint, int dim = 4) {
  ShardSets::Set s;
  s.layout.name = name;
  s.layout.place_ids.resize(static_cast<size_t>(places));
  std::iota(s.layout.place_ids.begin(), s.layout.place_ids.end(), 0);
  s.layout.dimension = dim;
  s.fingerprint = fingerprint;
  s.max_norm = 1;
  return s;
}

ShardSets Shard(const std::string& name, std::vector<ShardSets::Set> sets,
                const std::string& distance = "cosine") {
  return ShardSets{name, distance, std::move(sets)};
}

// shard's answer: set u's distances are u + 0.1 k (k the row), within cosine's bound.
ShardAnswer Answer(const ShardSets& shard, double seconds = 0.01) {
  ShardAnswer a;
  a.seconds = seconds;
  for (size_t u = 0; u < shard.sets.size(); ++u) {
    const ShardSets::Set& s = shard.sets[u];
    a.set_names.push_back(s.layout.name);
    a.fingerprints.push_back(s.fingerprint);
    RowMatrixXf d(1, s.layout.size());
    for (int k = 0; k < s.layout.size(); ++k) d(0, k) = 0.1f * static_cast<float>(u + k % 10);
    a.distances.push_back(d);
  }
  return a;
}

TEST(ShardAssembly, MergesTheShardsSetsInTheirOrderAndRefusesWhatCannotShareAMap) {
  const ShardSets a = Shard("/a", {OneSet("summer", 5, 1), OneSet("fall", 5, 2)});
  const ShardSets b = Shard("/b", {OneSet("winter", 7, 3)});
  const MergedLayout m = MergeShardLayouts({&a, nullptr, &b}, "euclidean", std::nullopt, 25);
  ASSERT_EQ(m.layout.num_sets(), 3);
  EXPECT_EQ(m.layout.set(0).name, "summer");
  EXPECT_EQ(m.layout.set(2).name, "winter");
  EXPECT_EQ(m.layout.num_places(), 7);
  EXPECT_EQ(m.metric, DistanceMetric::kCosine);  // the shards', not the fallback
  // No shard holds a set: the fallback's distance, an empty layout.
  const ShardSets none = Shard("/c", {}, "cosine");
  EXPECT_EQ(MergeShardLayouts({&none}, "euclidean", std::nullopt, 25).metric,
            DistanceMetric::kEuclidean);
  const auto refused = [](const std::vector<const ShardSets*>& shards,
                          std::optional<DistanceMetric> configured, const std::string& says) {
    try {
      MergeShardLayouts(shards, "cosine", configured, 25);
      ADD_FAILURE() << "not refused: " << says;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  const ShardSets twice = Shard("/d", {OneSet("summer", 5, 9)});
  refused({&a, &twice}, std::nullopt, "held by two shards");
  const ShardSets euclid = Shard("/e", {OneSet("night", 5, 4)}, "euclidean");
  refused({&a, &euclid}, std::nullopt, "different distances");
  const ShardSets wide = Shard("/f", {OneSet("night", 5, 4, 8)});
  refused({&a, &wide}, std::nullopt, "dimension 8");
  refused({&a}, DistanceMetric::kEuclidean, "this node euclidean");
  const ShardSets bad_name = Shard("/g", {OneSet(" night", 5, 4)});
  refused({&bad_name}, std::nullopt, "shard /g holds a set");
}

TEST(ShardAssembly, PutsEachShardsDistancesAtItsSetsAndLeavesOutWhatDoesNotFit) {
  const ShardSets a = Shard("/a", {OneSet("summer", 5, 1), OneSet("fall", 5, 2)});
  const ShardSets b = Shard("/b", {OneSet("winter", 7, 3)});
  const std::vector<std::string> names = {"/a", "/b", "/c"};
  const std::vector<const ShardSets*> shards = {&a, &b, nullptr};
  const PlaceLayout layout = MergeShardLayouts(shards, "cosine", std::nullopt, 25).layout;
  const ShardAnswer from_a = Answer(a, 0.02), from_b = Answer(b, 0.05);
  AssembledQuery q = AssembleShardAnswers(layout, names, shards, {from_a, from_b, std::nullopt},
                                          DistanceMetric::kCosine, 1.0, std::nullopt);
  ASSERT_EQ(q.distances.num_sets(), 3);
  EXPECT_EQ(q.distances.num_present(), 3);
  EXPECT_TRUE(q.distances.of(1).isApprox(from_a.distances[1]));
  EXPECT_EQ(q.distances.of(2)(0, 3), from_b.distances[0](0, 3));
  EXPECT_EQ(q.missing_shards, (std::vector<std::string>{"/c"}));  // no sets known
  EXPECT_EQ(q.seconds, 0.05);
  // Another fingerprint (a shard_info not taken yet): that shard's sets are absent.
  ShardAnswer stale = from_a;
  stale.fingerprints[1] = 99;
  q = AssembleShardAnswers(layout, names, shards, {stale, from_b, std::nullopt},
                           DistanceMetric::kCosine, 1.0, std::nullopt);
  EXPECT_FALSE(q.distances.present(0));
  EXPECT_FALSE(q.distances.present(1));
  EXPECT_TRUE(q.distances.present(2));
  EXPECT_EQ(q.missing_shards, (std::vector<std::string>{"/a", "/c"}));
  // Distances no exact distance can be: absent, and said why.
  ShardAnswer broken = from_b;
  broken.distances[0](0, 2) = std::numeric_limits<float>::quiet_NaN();
  q = AssembleShardAnswers(layout, names, shards, {from_a, broken, std::nullopt},
                           DistanceMetric::kCosine, 1.0, std::nullopt);
  EXPECT_FALSE(q.distances.present(2));
  EXPECT_NE(q.impossible[1].find("set 'winter': distance 2 of 7"), std::string::npos)
      << q.impossible[1];
  EXPECT_TRUE(q.impossible[0].empty());
  // One shard's refusal: that shard is missing. Every shard's: the descriptor is refused.
  ShardAnswer refusal;
  refusal.error = "dimension 3, the sets' 4";
  q = AssembleShardAnswers(layout, names, shards, {refusal, from_b, std::nullopt},
                           DistanceMetric::kCosine, 1.0, std::nullopt);
  EXPECT_EQ(q.distances.num_present(), 1);
  try {
    AssembleShardAnswers(layout, names, shards, {refusal, refusal, std::nullopt},
                         DistanceMetric::kCosine, 1.0, std::nullopt);
    FAIL() << "a descriptor every shard refused was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("shard /b: dimension 3"), std::string::npos);
  }
}

TEST(ShardAssembly, AttachesTheJointOfTheMostSetsThatFitsTheLayout) {
  const ShardSets a = Shard("/a", {OneSet("summer", 5, 1), OneSet("fall", 5, 2)});
  const ShardSets b = Shard("/b", {OneSet("winter", 5, 3)});
  const std::vector<std::string> names = {"/a", "/b"};
  const std::vector<const ShardSets*> shards = {&a, &b};
  const PlaceLayout layout = MergeShardLayouts(shards, "cosine", std::nullopt, 25).layout;
  ShardAnswer from_a = Answer(a), from_b = Answer(b);
  from_a.joint_kind = JointKind::kDiscriminant;
  from_a.joint_build = 7;
  from_a.joint_sets = {"summer", "fall"};
  from_a.joint_distances = RowMatrixXf::Constant(1, 5, 0.5f);
  AssembledQuery q = AssembleShardAnswers(layout, names, shards, {from_a, from_b},
                                          DistanceMetric::kCosine, 1.0, JointKind::kDiscriminant);
  ASSERT_TRUE(q.distances.joint().has_value());
  EXPECT_EQ(q.distances.joint()->build, (uint64_t{1} << 48) ^ 7);
  EXPECT_EQ(q.joint_from, "/a (2 sets)");
  // Not asked for, of another kind, or of a set the layout lacks: none attached.
  q = AssembleShardAnswers(layout, names, shards, {from_a, from_b}, DistanceMetric::kCosine, 1.0,
                           JointKind::kSubspace);
  EXPECT_FALSE(q.distances.joint().has_value());
  // A malformed answer: its sets are absent, its joint representation may still be used.
  ShardAnswer garbled = from_a;
  garbled.malformed = true;
  q = AssembleShardAnswers(layout, names, shards, {garbled, from_b}, DistanceMetric::kCosine, 1.0,
                           JointKind::kDiscriminant);
  EXPECT_FALSE(q.distances.present(0));
  EXPECT_EQ(q.missing_shards, (std::vector<std::string>{"/a"}));
  EXPECT_TRUE(q.distances.joint().has_value());
  from_a.joint_sets = {"summer", "night"};
  q = AssembleShardAnswers(layout, names, shards, {from_a, from_b}, DistanceMetric::kCosine, 1.0,
                           JointKind::kDiscriminant);
  EXPECT_FALSE(q.distances.joint().has_value());
  EXPECT_TRUE(q.joint_from.empty());
}

}  // namespace
}  // namespace bsf_vpr
