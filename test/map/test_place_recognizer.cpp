#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <optional>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/evaluation/synthetic.h"
#include "bsf_vpr/map/place_recognizer.h"

namespace bsf_vpr {
namespace {

SyntheticData Data() {
  SyntheticOptions opt;
  opt.num_places = 120;
  opt.dimension = 16;
  opt.set_noise = {0.3, 0.3};
  opt.condition_strength = 0.5;
  opt.query_noise = 0.3;
  return GenerateMultiConditionData(opt);
}

PlaceRecognizer Loaded(const SyntheticData& data, RecognizerOptions opt = {}) {
  PlaceRecognizer r(opt);
  for (const StoredReferenceSet& s : data.map.sets()) r.AddReferenceSet(s.ToReferenceSet());
  return r;
}

TEST(PlaceRecognizer, MatchesTheOfflineMethodForEveryQuery) {
  const SyntheticData data = Data();
  PlaceRecognizer r = Loaded(data);
  const std::vector<RowMatrixXf> all =
      ComputeDistances(DistanceMetric::kEuclidean, data.queries, data.map);
  // Offline as the evaluator runs it: one runner, the queries in order (the default fusion
  // carries its hypotheses' scores from query to query).
  // The default bsf takes the discriminant of the sets as one more hypothesis.
  MethodRunner runner(ParseMethod("bsf", data.map.SetNames()), {});
  std::vector<const StoredReferenceSet*> sets;
  for (const StoredReferenceSet& s : data.map.sets()) sets.push_back(&s);
  const JointRepresentation joint =
      JointRepresentation::Build(JointKind::kDiscriminant, sets, data.map.num_places());
  for (int q = 0; q < 30; ++q) {
    const Recognition online = r.Recognize(data.queries.row(q).transpose(), true);
    const RowMatrixXf jd = joint.Distances(data.queries.row(q));
    const std::vector<JointDistances> j = {
        {JointKind::kDiscriminant, {jd.data(), nullptr, data.map.num_places()}}};
    const PlaceBelief offline =
        runner.Step(QueryRowViews(all, q, {nullptr, nullptr}), data.map.num_places(), nullptr,
                    std::nullopt, true, nullptr, &j);
    EXPECT_GT(offline.joint_weight, 0.0);
    EXPECT_EQ(online.belief.match, offline.match);
    EXPECT_EQ(online.belief.confidence, offline.confidence);  // bitwise: the same distances
    ASSERT_GE(online.closest_set, 0);
  }
}

TEST(PlaceRecognizer, FilteredBeliefIsCarriedOnlyWhenUpdated) {
  const SyntheticData data = Data();
  RecognizerOptions opt;
  opt.method = "bsf+filter";
  PlaceRecognizer r = Loaded(data, opt);
  const Eigen::VectorXf q0 = data.queries.row(10).transpose();
  const Eigen::VectorXf q1 = data.queries.row(11).transpose();
  const Recognition first = r.Recognize(q1, false);  // what-if: state untouched
  const Recognition again = r.Recognize(q1, false);
  EXPECT_TRUE(first.belief.log_posterior.isApprox(again.belief.log_posterior));
  r.Recognize(q0, true);
  const Recognition with_prior = r.Recognize(q1, false);
  EXPECT_FALSE(with_prior.belief.log_posterior.isApprox(first.belief.log_posterior));
  r.ResetPrior();
  EXPECT_TRUE(r.Recognize(q1, false).belief.log_posterior.isApprox(first.belief.log_posterior));
}

TEST(PlaceRecognizer, ReconfiguringKeepsOnlyTheStateTheChangeLeavesValid) {
  const SyntheticData data = Data();
  RecognizerOptions opt;
  opt.method = "bsf+filter+seq";
  PlaceRecognizer r = Loaded(data, opt);
  for (int q = 0; q < 6; ++q) r.Recognize(data.queries.row(q).transpose(), true);
  const Eigen::VectorXf next = data.queries.row(6).transpose();
  const Recognition carried = r.Recognize(next, false);
  // A new threshold (or gamma, likelihood, filter step) keeps the filter and the sequence.
  RecognizerOptions h = opt;
  h.method_options.decision.threshold = Threshold{Threshold::Kind::kProbability, 0.999};
  r.SetOptions(h);
  const Recognition after_h = r.Recognize(next, false);
  EXPECT_TRUE(after_h.belief.cost.isApprox(carried.belief.cost));
  EXPECT_EQ(after_h.belief.match, carried.belief.match);
  // New sequence options restart the sequence history but keep the filtered belief: the
  // result equals a fresh sequence over the same filtered belief.
  RecognizerOptions seq = h;
  seq.method_options.sequence.length = 3;
  r.SetOptions(seq);
  const Recognition after_seq = r.Recognize(next, false);
  EXPECT_FALSE(after_seq.belief.cost.isApprox(carried.belief.cost));
  // Another method starts from nothing: the same as a new recogniser.
  RecognizerOptions other = seq;
  other.method = "bayes_full+filter";
  r.SetOptions(other);
  PlaceRecognizer fresh = Loaded(data, other);
  EXPECT_TRUE(
      r.Recognize(next, false)
          .belief.log_posterior.isApprox(fresh.Recognize(next, false).belief.log_posterior));
}

TEST(PlaceRecognizer, RefusesBadDescriptorsAndKeepsItsSets) {
  const SyntheticData data = Data();
  PlaceRecognizer empty;
  EXPECT_THROW(empty.Recognize(Eigen::VectorXf::Zero(16), true), std::invalid_argument);
  PlaceRecognizer r = Loaded(data);
  EXPECT_THROW(r.Recognize(Eigen::VectorXf::Zero(15), true), std::invalid_argument);
  Eigen::VectorXf nan = Eigen::VectorXf::Zero(16);
  nan(3) = NAN;
  EXPECT_THROW(r.Recognize(nan, true), std::invalid_argument);
  // Finite but so large that the distances would overflow: refused, not a NaN belief.
  Eigen::VectorXf huge = Eigen::VectorXf::Constant(16, 3.0e38f);
  EXPECT_THROW(r.Recognize(huge, true), std::invalid_argument);
  RecognizerOptions bad;
  bad.method = "nn:missing";
  EXPECT_THROW(r.SetOptions(bad), std::invalid_argument);
  EXPECT_EQ(r.options().method, "bsf");
  RecognizerOptions single;
  single.method = "nn:c1";
  r.SetOptions(single);
  EXPECT_THROW(r.RemoveReferenceSet("c1"), std::invalid_argument);
  // With suffixes too: the parsed method names the set it needs.
  for (const std::string m : {"nn:c1+seq", "bayes:c1+filter", "bayes:c1+filter+seq"}) {
    RecognizerOptions o;
    o.method = m;
    r.SetOptions(o);
    EXPECT_THROW(r.RemoveReferenceSet("c1"), std::invalid_argument) << m;
    EXPECT_EQ(r.num_sets(), 2);
    EXPECT_NO_THROW(r.Recognize(data.queries.row(0).transpose(), true)) << m;
  }
  r.SetOptions(single);
  EXPECT_THROW(r.RemoveReferenceSet("nope"), std::invalid_argument);
  r.RemoveReferenceSet("c0");
  EXPECT_EQ(r.num_sets(), 1);
  EXPECT_EQ(r.Recognize(data.queries.row(0).transpose(), true).belief.used_sets,
            std::vector<int>{0});
}

// A black or 1x1 image describes as zeros: its history alone must not make it a match.
TEST(PlaceRecognizer, AZeroDescriptorIsRefusedNotFusedAndTheBeliefGoesOn) {
  const SyntheticData data = Data();
  for (const std::string method : {"bsf+filter+seq", "bsf+filter", "bsf", "nn:c0+seq"}) {
    for (const DistanceMetric metric : {DistanceMetric::kEuclidean, DistanceMetric::kCosine}) {
      RecognizerOptions opt;
      opt.method = method;
      opt.metric = metric;
      PlaceRecognizer r = Loaded(data, opt);
      for (int q = 0; q < 30; ++q) r.Recognize(data.queries.row(q).transpose(), true);
      std::optional<Recognition> zero;
      std::string why;
      try {
        zero = r.Recognize(Eigen::VectorXf::Zero(16), true);
      } catch (const std::invalid_argument& e) {
        why = e.what();
      }
      EXPECT_FALSE(zero && zero->belief.accepted)
          << method << ": a zero descriptor was accepted as place " << zero->belief.match
          << " with confidence " << zero->belief.confidence;
      EXPECT_NE(why.find("all zeros"), std::string::npos) << method << ": " << why;
      // The refusal changed nothing: the next descriptor follows the first 30.
      PlaceRecognizer fresh = Loaded(data, opt);
      for (int q = 0; q < 30; ++q) fresh.Recognize(data.queries.row(q).transpose(), true);
      const Eigen::VectorXf next = data.queries.row(30).transpose();
      EXPECT_EQ(r.Recognize(next, true).belief.log_posterior,
                fresh.Recognize(next, true).belief.log_posterior)
          << method;
    }
  }
}

// The method is parsed once per change of the options or of the sets: the set it names is
// found again when the sets change, and a method that names a set not loaded is refused
// when it is needed, with the parser's message.
TEST(PlaceRecognizer, TheMethodFollowsTheSetsItNames) {
  const SyntheticData data = Data();
  const Eigen::VectorXf query = data.queries.row(0).transpose();
  RecognizerOptions o;
  o.method = "nn:c1";
  PlaceRecognizer r(o);  // no sets yet: nothing to resolve the method against
  r.AddReferenceSet(data.map.sets()[0].ToReferenceSet());
  try {
    r.Recognize(query, true);
    ADD_FAILURE() << "nn:c1 ran without c1";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("unknown reference set 'c1' (loaded: c0)"),
              std::string::npos)
        << e.what();
  }
  r.AddReferenceSet(data.map.sets()[1].ToReferenceSet());
  EXPECT_EQ(r.method().kind, MethodKind::kNearestNeighbour);
  EXPECT_EQ(r.method().set_index, 1);
  EXPECT_EQ(r.Recognize(query, true).belief.used_sets, std::vector<int>{1});
  r.RemoveReferenceSet("c0");
  EXPECT_EQ(r.method().set_index, 0);
  EXPECT_EQ(r.Recognize(query, true).belief.used_sets, std::vector<int>{0});
}

// The pca first stage through the recognizer: with every row re-ranked its recognitions are
// bitwise the exact ones; its index follows the map (a set added or removed is projected
// before the next query, not refused as another map), and a bad option is refused with the
// options in force kept.
TEST(PlaceRecognizer, PcaFirstStageFollowsTheMapAndIsExactWhenEveryRowIsReRanked) {
  const SyntheticData data = Data();
  RecognizerOptions pca;
  pca.first_stage.kind = "pca";
  pca.first_stage.approximate.dimensions = 4;
  pca.first_stage.approximate.rerank = data.map.num_places();  // every row exact
  PlaceRecognizer exact = Loaded(data);
  EXPECT_EQ(exact.index(), nullptr);
  PlaceRecognizer approximate = Loaded(data, pca);
  ASSERT_NE(approximate.index(), nullptr);  // built before the first query
  EXPECT_EQ(approximate.index()->dimensions(), 4);
  for (int q = 0; q < 20; ++q) {
    const Eigen::VectorXf query = data.queries.row(q).transpose();
    const Recognition a = exact.Recognize(query, true);
    const Recognition b = approximate.Recognize(query, true);
    EXPECT_EQ(a.belief.match, b.belief.match) << q;
    EXPECT_EQ(a.belief.confidence, b.belief.confidence) << q;
  }
  // Fewer candidates than places: approximate, but over a map that changes.
  pca.first_stage.approximate.rerank = 3;
  EXPECT_THROW(approximate.SetOptions(pca), std::invalid_argument);  // the map's, fixed
  approximate = Loaded(data, pca);
  approximate.RemoveReferenceSet("c1");
  EXPECT_EQ(approximate.Recognize(data.queries.row(0).transpose(), true).belief.used_sets,
            std::vector<int>{0});
  approximate.AddReferenceSet(data.map.sets()[1].ToReferenceSet());
  EXPECT_NO_THROW(approximate.Recognize(data.queries.row(1).transpose(), true));
  RecognizerOptions bad = pca;
  bad.first_stage.kind = "pq";
  EXPECT_THROW(approximate.SetOptions(bad), std::invalid_argument);
  bad = pca;
  bad.first_stage.approximate.dimensions = 0;
  EXPECT_THROW(approximate.SetOptions(bad), std::invalid_argument);
  EXPECT_EQ(approximate.options().first_stage.approximate.rerank, 3);
  EXPECT_THROW(PlaceRecognizer{bad}, std::invalid_argument);
  // The option table names the parameters the node and bsf_evaluate take.
  RecognizerOptions parsed;
  EXPECT_TRUE(RecognizerOptionsTable().SetFromFlag("--first-stage", "pca", &parsed));
  EXPECT_EQ(parsed.first_stage.kind, "pca");
  EXPECT_TRUE(RecognizerOptionsTable().SetFromFlag("--rerank-candidates", "7", &parsed));
  EXPECT_EQ(parsed.first_stage.approximate.rerank, 7);
  EXPECT_THROW(RecognizerOptionsTable().SetFromFlag("--first-stage", "faiss", &parsed),
               std::invalid_argument);
}

// A sharded map: each shard holds some of the sets and computes their distances alone; a
// decider on the whole map's layout (no descriptors) fuses them and gives bitwise
// the single recognizer's beliefs, for every method with +filter and +seq, with 2 and 3
// shards, both metrics, float32 and int8 storage.
TEST(PlaceRecognizer, ShardedDistancesGiveBitwiseTheSingleRecognizersBeliefs) {
  SyntheticOptions opt;
  opt.num_places = 90;
  opt.dimension = 24;
  opt.set_noise = {0.3, 0.4, 0.6};
  opt.condition_strength = 0.5;
  opt.query_noise = 0.3;
  const SyntheticData data = GenerateMultiConditionData(opt);
  const std::vector<std::vector<std::vector<int>>> shardings = {{{0}, {1, 2}}, {{2}, {0}, {1}}};
  for (const StoragePrecision precision : {StoragePrecision::kFloat32, StoragePrecision::kInt8}) {
    for (const DistanceMetric metric : {DistanceMetric::kEuclidean, DistanceMetric::kCosine}) {
      for (const std::string method :
           {"bsf", "bsf+filter", "bsf+seq", "bsf+filter+seq", "bayes_full+filter", "med",
            "med_selective+seq", "nn:c1+seq", "bayes:c2+filter"}) {
        for (const auto& shards : shardings) {
          RecognizerOptions o;
          o.method = method;
          o.metric = metric;
          // The sets' distances alone (the joint representation's own: PlaceDecider tests).
          o.method_options.fusion_joint = FusionJoint::kNone;
          PlaceRecognizer single(o, precision);
          std::vector<PlaceRecognizer> holders;
          for (const StoredReferenceSet& s : data.map.sets())
            single.AddReferenceSet(s.ToReferenceSet());
          // The combiner holds the sets' layout alone, as the fusion node's sharded map does.
          const PlaceLayout layout = data.map.layout();
          PlaceDecider combiner(o.method, o.method_options);
          combiner.OnLayoutChanged(layout);
          for (size_t k = 0; k < shards.size(); ++k) {
            RecognizerOptions metric_only;  // a shard computes distances, it decides nothing
            metric_only.metric = metric;
            metric_only.method_options.fusion_joint = FusionJoint::kNone;
            holders.emplace_back(metric_only, precision);
            for (int u : shards[k]) holders[k].AddReferenceSet(data.map.set(u).ToReferenceSet());
          }
          const std::string what = method + ", " + ToString(metric) + ", " + ToString(precision) +
                                   ", " + std::to_string(shards.size()) + " shards";
          for (int q = 0; q < 25; ++q) {
            const Eigen::VectorXf query = data.queries.row(q).transpose();
            QueryDistances distances(3);
            for (size_t k = 0; k < shards.size(); ++k) {
              const QueryDistances own = holders[k].Distances(query);
              for (size_t i = 0; i < shards[k].size(); ++i) {
                distances.Set(shards[k][i], own.of(static_cast<int>(i)));
              }
            }
            const Recognition a = single.Recognize(query, true);
            const Recognition b = combiner.Decide(layout, distances, true);
            ASSERT_EQ(a.belief.match, b.belief.match) << what << ", query " << q;
            ASSERT_EQ(std::memcmp(&a.belief.confidence, &b.belief.confidence, sizeof(double)), 0)
                << what << ", query " << q;
            ASSERT_EQ(a.belief.accepted, b.belief.accepted) << what;
            ASSERT_EQ(a.belief.top_places, b.belief.top_places) << what;
            ASSERT_EQ(a.belief.log_posterior.size(), b.belief.log_posterior.size()) << what;
            // Distance methods have no posterior (and memcmp may not be given null).
            if (a.belief.log_posterior.size() > 0) {
              ASSERT_EQ(std::memcmp(a.belief.log_posterior.data(), b.belief.log_posterior.data(),
                                    sizeof(double) * a.belief.log_posterior.size()),
                        0)
                  << what << ", query " << q;
            }
            ASSERT_EQ(a.closest_set, b.closest_set) << what;
          }
        }
      }
    }
  }
}

// The recogniser's decision is the decider's on the map's distances: a decider holding the
// layout alone (a sharded map's combiner) decides bitwise the same.
TEST(PlaceRecognizer, DecidesBitwiseAsADeciderOnItsDistances) {
  const SyntheticData data = Data();
  for (const std::string method : {"bsf", "bsf+filter+seq", "bayes_full", "med"}) {
    RecognizerOptions options;
    options.method = method;
    PlaceRecognizer whole(options);
    for (const StoredReferenceSet& s : data.map.sets()) whole.AddReferenceSet(s.ToReferenceSet());
    PlaceLayout layout;
    for (const SetLayout& s : whole.layout()->sets()) layout.Add(s);
    PlaceDecider decider(method, options.method_options);
    decider.OnLayoutChanged(layout);
    for (int q = 0; q < 25; ++q) {
      const Eigen::VectorXf query = data.queries.row(q).transpose();
      const QueryDistances d = whole.Distances(query);
      EXPECT_EQ(d.joint().has_value(), method.rfind("bsf", 0) == 0) << method;
      const Recognition a = whole.Recognize(query, true);
      const Recognition b = decider.Decide(layout, d, true);
      ASSERT_EQ(a.belief.match, b.belief.match) << method << " query " << q;
      ASSERT_EQ(a.belief.confidence, b.belief.confidence) << method << " query " << q;
      ASSERT_EQ(a.closest_set, b.closest_set);
      EXPECT_TRUE(b.missing_sets.empty());
    }
  }
}

// What a shard sends is checked: the count of sets, each one's size, and its values.
TEST(PlaceRecognizer, DecideRefusesWhatCannotBeTheSetsDistances) {
  const SyntheticData data = Data();
  PlaceRecognizer r = Loaded(data);
  const std::vector<RowMatrixXf> good =
      ComputeDistances(DistanceMetric::kEuclidean, data.queries.topRows(1), data.map);
  EXPECT_NO_THROW(r.Decide(QueryDistances::AllPresent(good), false));
  EXPECT_THROW(r.Decide(QueryDistances::AllPresent({good[0]}), true), std::invalid_argument);
  std::vector<RowMatrixXf> bad = good;
  bad[1] = good[1].leftCols(5);
  EXPECT_THROW(r.Decide(QueryDistances::AllPresent(bad), true), std::invalid_argument);
  for (const float value : {-1.0f, NAN, INFINITY}) {
    bad = good;
    bad[0](0, 3) = value;
    EXPECT_THROW(r.Decide(QueryDistances::AllPresent(bad), true), std::invalid_argument) << value;
  }
  PlaceRecognizer empty;
  EXPECT_THROW(empty.Decide(QueryDistances(), true), std::invalid_argument);
  // Every set absent: nothing to decide on.
  EXPECT_THROW(r.Decide(QueryDistances(static_cast<int>(good.size())), true),
               std::invalid_argument);
}

// A shard that does not answer: the combiner decides on the sets it has, exactly as a
// recognizer that holds only those sets would (same places, same carried state), and names
// the missing sets; the belief still indexes every set of the map. When the shard answers
// again, the next belief fuses every set.
TEST(PlaceRecognizer, MissingSetsAreLeftOutAsIfTheyWereNotLoaded) {
  SyntheticOptions opt;
  opt.num_places = 120;
  opt.dimension = 16;
  opt.set_noise = {0.3, 0.35, 0.4};  // three sets covering the same places
  opt.condition_strength = 0.5;
  opt.query_noise = 0.3;
  const SyntheticData data = GenerateMultiConditionData(opt);
  for (const std::string method : {"bsf", "bsf+filter+seq", "bayes_full+filter", "med+seq",
                                   "med_selective", "nn:c0", "nn:c2+seq", "bayes:c2+filter"}) {
    RecognizerOptions o;
    o.method = method;
    o.method_options.fusion_joint = FusionJoint::kNone;  // the sets' distances alone
    PlaceRecognizer without_c1(o);
    for (const StoredReferenceSet& s : data.map.sets()) {
      if (s.name() != "c1") without_c1.AddReferenceSet(s.ToReferenceSet());
    }
    const PlaceLayout layout = data.map.layout();  // the combiner's: no descriptors
    PlaceDecider combiner(o.method, o.method_options);
    combiner.OnLayoutChanged(layout);
    for (int q = 0; q < 12; ++q) {
      const RowMatrixXf query = data.queries.row(q);
      const std::vector<RowMatrixXf> all =
          ComputeDistances(DistanceMetric::kEuclidean, query, data.map);
      QueryDistances d(3);
      d.Set(0, all[0]);
      d.Set(2, all[2]);  // c1's shard did not answer
      const Recognition a = without_c1.Recognize(query.row(0).transpose(), true);
      const Recognition b = combiner.Decide(layout, d, true);
      ASSERT_EQ(b.missing_sets, std::vector<int>{1}) << method;
      ASSERT_EQ(a.belief.match, b.belief.match) << method << ", query " << q;
      ASSERT_EQ(a.belief.confidence, b.belief.confidence) << method << ", query " << q;
      ASSERT_EQ(a.belief.log_posterior.size(), b.belief.log_posterior.size());
      for (Eigen::Index i = 0; i < a.belief.log_posterior.size(); ++i) {
        ASSERT_EQ(a.belief.log_posterior[i], b.belief.log_posterior[i]) << method;
      }
      // Indexed by the map's sets: c1 has weight 0, NaN statistics, is never used.
      ASSERT_EQ(b.belief.set_weights.size(), 3u);
      EXPECT_EQ(b.belief.set_weights[1], 0.0);
      EXPECT_TRUE(std::isnan(b.belief.selection.set_stats.at(1).min));
      for (int u : b.belief.used_sets) EXPECT_NE(u, 1) << method;
      for (int u : b.belief.selection.selected) EXPECT_NE(u, 1) << method;
      // The others in the map's numbering (c2 is set 2 here, set 1 in without_c1).
      EXPECT_EQ(b.belief.selection.set_stats.at(2).min, a.belief.selection.set_stats.at(1).min);
      EXPECT_EQ(b.belief.set_weights[2], a.belief.set_weights.at(1));
      EXPECT_EQ(b.closest_set, a.closest_set == 1 ? 2 : a.closest_set) << method;
    }
    // c1 answers again: every set is fused, and nothing is missing.
    const RowMatrixXf query = data.queries.row(12);
    const Recognition back = combiner.Decide(
        layout,
        QueryDistances::AllPresent(ComputeDistances(DistanceMetric::kEuclidean, query, data.map)),
        true);
    EXPECT_TRUE(back.missing_sets.empty());
    EXPECT_EQ(back.belief.set_weights.size(), 3u);
    EXPECT_FALSE(std::isnan(back.belief.selection.set_stats.at(1).min));
  }
  // nn: of a missing set cannot be answered; the state is left as it was.
  RecognizerOptions o;
  o.method = "nn:c1";
  PlaceRecognizer r = Loaded(data);
  r.SetOptions(o);
  const std::vector<RowMatrixXf> all =
      ComputeDistances(DistanceMetric::kEuclidean, data.queries.topRows(1), data.map);
  QueryDistances d(3);
  d.Set(0, all[0]);
  d.Set(2, all[2]);
  EXPECT_THROW(r.Decide(d, true), std::invalid_argument);
}

// With max_false_accept_rate the recogniser's map calibrates itself (once, at the first query
// after a change) and its rule decides beside the threshold: on a map of half the route, a
// traversal that runs past its end has its look-alikes turned down and its matches kept.
TEST(PlaceRecognizer, TheMapsOwnRuleTurnsDownLookAlikesPastTheMapsEnd) {
  SyntheticOptions syn;
  syn.num_places = 150;
  syn.dimension = 24;
  syn.set_noise = {0.35, 0.35, 0.35};
  syn.seed = 3;
  const SyntheticData data = GenerateMultiConditionData(syn);
  RecognizerOptions options;
  options.method = "bsf+filter";
  options.method_options.off_map.enabled = false;  // a look-alike takes the whole posterior
  options.method_options.decision.threshold = {Threshold::Kind::kProbability, 0.5};
  int off_accepted[2] = {0, 0}, right[2] = {0, 0};
  for (int ruled = 0; ruled < 2; ++ruled) {
    options.calibration.max_false_accept_rate = ruled ? 0.02 : 0;
    PlaceRecognizer r(options);
    for (const StoredReferenceSet& s : data.map.sets()) {
      ReferenceSet set = s.ToReferenceSet();
      set.descriptors.conservativeResize(75, Eigen::NoChange);
      set.place_ids.resize(75);
      r.AddReferenceSet(std::move(set));
    }
    for (int q = 0; q < 150; ++q) {
      const Recognition out = r.Recognize(data.queries.row(q).transpose(), true);
      if (!out.belief.accepted) continue;
      off_accepted[ruled] += q >= 78;
      right[ruled] += q < 75 && std::abs(out.belief.match - q) <= 2;
    }
  }
  EXPECT_GT(off_accepted[0], 5);
  // 72 off-map queries at a target of 2%: measured 3, within twice the target (the live map
  // fuses three traversals and their joint representation, the calibration held one out).
  EXPECT_LE(off_accepted[1], 3);
  EXPECT_GT(right[1], 40);
}

}  // namespace
}  // namespace bsf_vpr
