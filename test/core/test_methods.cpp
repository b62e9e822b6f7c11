#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/methods.h"
#include "test/core/enum_names_check.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

const std::vector<std::string> kNames = {"summer", "winter", "fall"};

struct Data {
  std::vector<std::vector<float>> d;
  std::vector<SetDistances> views;
  Data(int n, uint64_t seed) {
    for (int u = 0; u < 3; ++u) d.push_back(testing::RandomDistances(n, seed * 10 + u));
    for (const auto& x : d) views.push_back({x.data(), nullptr, n});
  }
};

// One query run and decided (RunMethod fuses; the runner decides).
PlaceBelief Decided(const Method& m, const std::vector<SetDistances>& views, int n,
                    const MethodOptions& o, const std::vector<JointDistances>* joint = nullptr) {
  return MethodRunner(m, o).Step(views, n, nullptr, std::nullopt, true, nullptr, joint);
}

TEST(Methods, MedEqualsEquationMed) {
  for (uint64_t seed = 1; seed <= 30; ++seed) {
    Data data(100, seed);
    const PlaceBelief b = RunMethod(ParseMethod("med", kNames), data.views, 100, {});
    int best = 0;
    float best_sum = INFINITY;
    for (int i = 0; i < 100; ++i) {
      const float s = data.d[0][i] + data.d[1][i] + data.d[2][i];
      if (s < best_sum) best_sum = s, best = i;
    }
    EXPECT_EQ(b.match, best);
    EXPECT_NEAR(b.confidence, -best_sum / 3.0, 1e-5);
    EXPECT_EQ(b.used_sets, (std::vector<int>{0, 1, 2}));
  }
}

TEST(Methods, NearestNeighbourIsTheMinimumValuePrinciple) {
  Data data(80, 4);
  const PlaceBelief b = RunMethod(ParseMethod("nn:winter", kNames), data.views, 80, {});
  const int expected =
      static_cast<int>(std::min_element(data.d[1].begin(), data.d[1].end()) - data.d[1].begin());
  EXPECT_EQ(b.match, expected);
  EXPECT_EQ(b.used_sets, std::vector<int>{1});
  EXPECT_EQ(b.log_posterior.size(), 0);
}

TEST(Methods, SelectedAndUsedSetsAreKeptApart) {
  // What the rule selected is reported for every method; what the method fused beside it.
  Data data(120, 7);
  MethodOptions narrow;
  narrow.fusion = FusionRule::kProduct;
  narrow.selection.gamma_fraction = 0.0;  // S = {u*}
  const PlaceBelief bsf = RunMethod(ParseMethod("bsf", kNames), data.views, 120, narrow);
  ASSERT_EQ(bsf.selection.selected.size(), 1u);
  EXPECT_EQ(bsf.used_sets, bsf.selection.selected);
  for (const std::string name : {"bayes_full", "med", "nn:fall"}) {
    const PlaceBelief b = RunMethod(ParseMethod(name, kNames), data.views, 120, narrow);
    EXPECT_EQ(b.selection.selected, bsf.selection.selected) << name;  // the rule's S
    const std::vector<int> expected =
        name == "nn:fall" ? std::vector<int>{2} : std::vector<int>{0, 1, 2};
    EXPECT_EQ(b.used_sets, expected) << name;
  }
  // Explicit statistics give the same posterior as computing them inside.
  PlaceBelief with, without;
  const Selection s = SelectReferenceSets(data.views, {});
  FuseBayes(data.views, {0, 1}, 120, {}, nullptr, &with, &s.set_stats);
  FuseBayes(data.views, {0, 1}, 120, {}, nullptr, &without);
  EXPECT_TRUE(with.log_posterior.isApprox(without.log_posterior));
  const std::vector<DistanceStats> short_stats(1);
  EXPECT_THROW(FuseBayes(data.views, {0}, 120, {}, nullptr, &with, &short_stats),
               std::invalid_argument);
}

TEST(Methods, BsfWithLargeGammaIsBayesFullAndWithZeroGammaTheBestSetAlone) {
  Data data(150, 9);
  MethodOptions wide;  // the paper's product fusion
  wide.fusion = FusionRule::kProduct;
  wide.selection.gamma_fraction = 1e9;
  const PlaceBelief all = RunMethod(ParseMethod("bsf", kNames), data.views, 150, wide);
  const PlaceBelief full = RunMethod(ParseMethod("bayes_full", kNames), data.views, 150, {});
  EXPECT_EQ(all.match, full.match);
  EXPECT_TRUE(all.log_posterior.isApprox(full.log_posterior));

  MethodOptions narrow;
  narrow.fusion = FusionRule::kProduct;
  narrow.selection.gamma_fraction = 0.0;
  const PlaceBelief one = RunMethod(ParseMethod("bsf", kNames), data.views, 150, narrow);
  ASSERT_EQ(one.selection.selected.size(), 1u);
  const std::string best_name = kNames[static_cast<size_t>(one.selection.best)];
  const PlaceBelief single =
      RunMethod(ParseMethod("bayes:" + best_name, kNames), data.views, 150, {});
  EXPECT_TRUE(one.log_posterior.isApprox(single.log_posterior));

  const PlaceBelief meds = RunMethod(ParseMethod("med_selective", kNames), data.views, 150, narrow);
  const PlaceBelief nn = RunMethod(ParseMethod("nn:" + best_name, kNames), data.views, 150, {});
  EXPECT_EQ(meds.match, nn.match);
}

TEST(Methods, NamesParseAndUnknownNamesAreRefusedWithTheChoices) {
  EXPECT_EQ(AllMethods(kNames).size(), 10u);
  EXPECT_EQ(ParseMethodList("all", kNames).size(), 10u);
  const auto list = ParseMethodList("bsf,nn:fall,bsf", kNames);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[1].Name(), "nn:fall");
  EXPECT_EQ(list[1].set_index, 2);
  try {
    ParseMethod("nn:spring", kNames);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("spring"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("summer, winter, fall"), std::string::npos);
  }
  EXPECT_THROW(ParseMethod("seqslam", kNames), std::invalid_argument);
  EXPECT_THROW(ParseMethodList(",", kNames), std::invalid_argument);
}

// The methods' one table of names: every method AllMethods lists (every kind, nn and bayes
// once per set) reads back through its Name, and an unknown method is refused with a message
// that names every one as it is written.
TEST(Methods, EveryMethodNameRoundTripsThroughTheOneTable) {
  testing::ExpectNamesRoundTrip<MethodKind>(MethodKindNames(), nullptr, "method");
  const std::vector<Method> all = AllMethods(kNames, /*joint_methods=*/true);
  EXPECT_EQ(all.size(), MethodKindNames().entries().size() - 2 + 2 * kNames.size());
  for (const auto& [kind, name] : MethodKindNames().entries()) {
    EXPECT_TRUE(std::any_of(all.begin(), all.end(), [&wanted = kind](const Method& m) {
      return m.kind == wanted;
    })) << name;
  }
  for (const Method& m : all) {
    const Method back = ParseMethod(m.Name(), kNames);
    EXPECT_EQ(back.kind, m.kind) << m.Name();
    EXPECT_EQ(back.set_index, m.set_index) << m.Name();
    EXPECT_EQ(back.Name(), m.Name());
  }
  EXPECT_EQ(all.front().Name(), "bsf");
  EXPECT_EQ(all.back().Name(), "nn:fall");
  try {
    ParseMethod("seqslam", kNames);
    FAIL();
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    for (const Method& m : AllMethods({"<set>"}, true)) {
      EXPECT_NE(message.find(m.Name()), std::string::npos) << m.Name() << " in " << message;
    }
  }
  // A method that runs on one set needs its name; the others take none.
  EXPECT_THROW(ParseMethod("nn", kNames), std::invalid_argument);
  EXPECT_THROW(ParseMethod("bsf:winter", kNames), std::invalid_argument);
  EXPECT_EQ(ParseMethod("bayes:winter+seq", kNames).Name(), "bayes:winter+seq");
}

TEST(Methods, SuffixesParseAndNeedWhatTheyUse) {
  const std::vector<std::string> sets = {"a", "b"};
  const Method m = ParseMethod("bsf+filter+seq", sets);
  EXPECT_TRUE(m.temporal_filter);
  EXPECT_TRUE(m.sequence);
  EXPECT_EQ(m.Name(), "bsf+filter+seq");
  EXPECT_EQ(ParseMethod("nn:b+seq", sets).set_index, 1);
  EXPECT_EQ(ParseMethod("bsf+seq+filter", sets).Name(), "bsf+filter+seq");
  EXPECT_THROW(ParseMethod("nn:a+filter", sets), std::invalid_argument);  // no posterior
  EXPECT_THROW(ParseMethod("bsf+smooth", sets), std::invalid_argument);
}

TEST(Methods, DistanceMethodsAreGatedByMaxMatchDistance) {
  Data data(100, 5);
  for (const std::string name : {"nn:winter", "med", "med_selective"}) {
    const Method m = ParseMethod(name, kNames);
    const PlaceBelief strict = Decided(m, data.views, 100, {});  // default 0
    EXPECT_FALSE(strict.accepted) << name;
    const double distance = -strict.confidence;
    MethodOptions o;
    o.decision.max_match_distance = distance;  // exactly the match's distance: accepted
    EXPECT_TRUE(Decided(m, data.views, 100, o).accepted) << name;
    o.decision.max_match_distance = distance * 0.999;
    EXPECT_FALSE(Decided(m, data.views, 100, o).accepted) << name;
  }
  MethodOptions bad;
  bad.decision.max_match_distance = -1;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad.decision.max_match_distance = NAN;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

TEST(Methods, ANanDistanceNeverGivesAnAcceptedBelief) {
  Data data(50, 6);
  data.d[0][7] = NAN;
  data.d[1][7] = NAN;
  data.d[2][7] = NAN;
  MethodOptions o;
  o.decision.threshold = Threshold{Threshold::Kind::kLogOdds, -1000};
  try {
    const PlaceBelief b = RunMethod(ParseMethod("bayes_full", kNames), data.views, 50, o);
    EXPECT_FALSE(b.log_posterior.hasNaN());
    EXPECT_FALSE(std::isnan(b.confidence));
  } catch (const std::invalid_argument&) {
    // Refusing the query is as good: nothing is published.
  }
}

// The paper's exact method by name (--fusion product --likelihood two_sided, relative
// selection) against the O(N^2) oracle: Eq. reference_selection by division, and the sum of
// Eq. obsLikelihoods over the selected sets.
TEST(Methods, PaperModeMatchesTheOracle) {
  MethodOptions paper;
  paper.fusion = FusionRule::kProduct;
  paper.likelihood.variant = LikelihoodVariant::kTwoSided;
  paper.selection.gamma_fraction = 0.1;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    Data data(70, seed + 100);
    for (float& v : data.d[1]) v *= 1.05f;  // a second set near the first: selected sometimes
    const PlaceBelief b = RunMethod(ParseMethod("bsf", kNames), data.views, 70, paper);
    double best_min = INFINITY;
    for (const auto& x : data.d)
      best_min = std::min<double>(best_min, *std::min_element(x.begin(), x.end()));
    std::vector<int> selected;
    for (int u = 0; u < 3; ++u) {
      const double m = *std::min_element(data.d[u].begin(), data.d[u].end());
      if ((m - best_min) / best_min <= 0.1 + 1e-12) selected.push_back(u);
    }
    EXPECT_EQ(b.selection.selected, selected) << "seed " << seed;
    Eigen::VectorXd expected = Eigen::VectorXd::Zero(70);
    for (int u : selected) {
      for (int i = 0; i < 70; ++i) expected(i) += testing::LogLikelihoodOracle(data.d[u], i, false);
    }
    expected.array() -=
        std::log((expected.array() - expected.maxCoeff()).exp().sum()) + expected.maxCoeff();
    for (int i = 0; i < 70; ++i)
      ASSERT_NEAR(b.log_posterior(i), expected(i), 1e-9) << "seed " << seed;
  }
}

// The mixture fusion (the default bsf) against its equation, computed the straightforward way:
// pooled statistics over the group, each set's likelihood scaled to mean 1 over the places
// it covers (1 where it covers none), mixed with the soft selection weights; two groups
// multiply. Sets cover different places (place ids), and the prior is not uniform.
TEST(Methods, MixtureFusionMatchesItsEquation) {
  const int n = 60;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    std::vector<std::vector<float>> d;
    std::vector<std::vector<int>> ids;
    for (int u = 0; u < 4; ++u) {
      d.push_back(testing::RandomDistances(n - 10 * (u % 2), seed * 10 + u));
      for (float& v : d.back()) v *= 1.0f + 0.02f * static_cast<float>(u);  // close minima
      ids.emplace_back();
      for (int k = 0; k < static_cast<int>(d.back().size()); ++k)
        ids.back().push_back((k + 7 * u) % n);
    }
    std::vector<SetDistances> views;
    for (int u = 0; u < 4; ++u) {
      views.push_back({d[u].data(), ids[u].data(), static_cast<int>(d[u].size()), u < 3 ? 0 : 1});
    }
    Eigen::VectorXd prior(n);
    for (int i = 0; i < n; ++i) prior(i) = -0.01 * i;
    MethodOptions options;
    options.fusion = FusionRule::kMixture;
    options.selection.gamma_fraction = 0.05;
    const std::vector<std::string> names = {"a", "b", "c", "d"};
    const PlaceBelief b = RunMethod(ParseMethod("bsf", names), views, n, options, &prior);

    Eigen::VectorXd expected = prior;
    for (const std::vector<int>& group : {std::vector<int>{0, 1, 2}, std::vector<int>{3}}) {
      double sum = 0, count = 0;
      for (int u : group) {
        for (float v : d[u]) sum += v, ++count;
      }
      const double mean = sum / count;
      double ss = 0;
      for (int u : group) {
        for (float v : d[u]) ss += (v - mean) * (v - mean);
      }
      const double var = ss / count;
      double best_min = INFINITY;
      for (int u : group)
        best_min = std::min<double>(best_min, *std::min_element(d[u].begin(), d[u].end()));
      std::vector<double> w;
      for (int u : group) {
        const double m = *std::min_element(d[u].begin(), d[u].end());
        w.push_back(std::exp(-(m - best_min) / (0.05 * best_min)));
        EXPECT_NEAR(b.set_weights[static_cast<size_t>(u)], w.back(), 1e-9);
      }
      const double total = std::accumulate(w.begin(), w.end(), 0.0);
      Eigen::VectorXd mix = Eigen::VectorXd::Zero(n);
      for (size_t j = 0; j < group.size(); ++j) {
        const std::vector<float>& x = d[group[j]];
        std::vector<double> l(x.size());
        double mean_exp = 0;
        for (size_t k = 0; k < x.size(); ++k) {
          const double e = std::min(0.0, x[k] - mean);
          l[k] = std::log(static_cast<double>(testing::RankCountOracle(x, k))) + e * e / (2 * var);
          mean_exp += std::exp(l[k]) / static_cast<double>(x.size());
        }
        Eigen::VectorXd like = Eigen::VectorXd::Ones(n);  // 1 where the set covers nothing
        for (size_t k = 0; k < x.size(); ++k) like(ids[group[j]][k]) = std::exp(l[k]) / mean_exp;
        mix += w[j] / total * like;
      }
      expected += mix.array().log().matrix();
    }
    expected.array() -= std::log(expected.array().exp().sum());
    ASSERT_EQ(b.log_posterior.size(), n);
    for (int i = 0; i < n; ++i)
      ASSERT_NEAR(b.log_posterior(i), expected(i), 1e-9) << "seed " << seed << " i " << i;
    Eigen::Index best = 0;
    expected.maxCoeff(&best);
    EXPECT_EQ(b.match, best);
  }
}

TEST(Methods, MixtureOfOneSetPerGroupIsBayesFullAndSelectionIsPerGroup) {
  Data data(90, 5);
  for (size_t u = 0; u < 3; ++u) data.views[u].group = static_cast<int>(u);
  const PlaceBelief mix = RunMethod(ParseMethod("bsf", kNames), data.views, 90, {});
  const PlaceBelief full = RunMethod(ParseMethod("bayes_full", kNames), data.views, 90, {});
  EXPECT_TRUE(mix.log_posterior.isApprox(full.log_posterior, 1e-12));
  // Each set is the best of its own group: all selected, all of weight 1, all used.
  EXPECT_EQ(mix.selection.selected, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(mix.used_sets, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(mix.set_weights, (std::vector<double>{1, 1, 1}));
  // The product fusion (the paper) ignores groups: its rule compares every set.
  MethodOptions paper;
  paper.fusion = FusionRule::kProduct;
  const PlaceBelief product = RunMethod(ParseMethod("bsf", kNames), data.views, 90, paper);
  EXPECT_EQ(product.selection.selected, SelectReferenceSets(data.views, {}).selected);
}

TEST(Methods, TheMixtureRefusesNaNDistancesAndSurvivesATinyWeight) {
  Data data(50, 3);
  data.d[0][0] = NAN;
  EXPECT_THROW(RunMethod(ParseMethod("bsf", kNames), data.views, 50, {}), std::invalid_argument);
  // A set far from the closest (weight e^-200, which underflows nowhere in the log domain)
  // leaves a finite posterior.
  Data far(50, 4);
  for (float& v : far.d[2]) v *= 9.0f;
  MethodOptions o;
  o.fusion = FusionRule::kMixture;
  o.selection.gamma_fraction = 0.01;
  const PlaceBelief b = RunMethod(ParseMethod("bsf", kNames), far.views, 50, o);
  EXPECT_TRUE(b.log_posterior.allFinite());
  EXPECT_LT(b.set_weights[2], 1e-30);
  EXPECT_EQ(b.used_sets.size(), b.set_weights[2] > 0 ? 3u : 2u);
}

TEST(Methods, ConditionWeightsAreTheSoftFormOfTheSelectionRule) {
  // Minima 1.0, 1.04 (on the boundary of gamma 0.04), 1.2 and 0 in another group.
  std::vector<std::vector<float>> d = {{1.0f, 3.0f}, {1.04f, 3.0f}, {1.2f, 3.0f}, {0.0f, 1.0f}};
  std::vector<SetDistances> views;
  for (size_t u = 0; u < d.size(); ++u) views.push_back({d[u].data(), nullptr, 2, u < 3 ? 0 : 1});
  SelectionOptions o;
  o.gamma_fraction = 0.04;
  const Selection s = SelectReferenceSets(views, o, true);
  const std::vector<double> w = ConditionWeights(views, s.set_stats, o);
  EXPECT_DOUBLE_EQ(w[0], 1.0);
  EXPECT_NEAR(w[1], std::exp(-1.0), 1e-6);  // float minima: 1.04f is not exactly 1.04
  EXPECT_NEAR(w[2], std::exp(-5.0), 1e-5);
  EXPECT_DOUBLE_EQ(w[3], 1.0);  // the best of its group, though its minimum is 0
  EXPECT_EQ(s.selected, (std::vector<int>{0, 1, 3}));
  o.gamma_fraction = 0;  // hard: only ties with the best
  const std::vector<double> hard = ConditionWeights(views, s.set_stats, o);
  EXPECT_EQ(hard, (std::vector<double>{1, 0, 0, 1}));
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

TEST(Methods, UnionNnIsBayesOnEachPlacesSmallestDistance) {
  Data data(60, 7);
  const PlaceBelief b = RunMethod(ParseMethod("union_nn", kNames), data.views, 60, {});
  std::vector<float> smallest(60);
  for (int i = 0; i < 60; ++i) smallest[i] = std::min({data.d[0][i], data.d[1][i], data.d[2][i]});
  std::vector<SetDistances> one = {{smallest.data(), nullptr, 60}};
  PlaceBelief expected;
  FuseBayes(one, {0}, 60, {}, nullptr, &expected);
  EXPECT_EQ(b.match, expected.match);
  EXPECT_DOUBLE_EQ(b.confidence, expected.confidence);
  EXPECT_EQ(b.used_sets, (std::vector<int>{0, 1, 2}));
  // Sets that share no place, or of several descriptors, are refused.
  std::vector<int> first = {0, 1, 2}, second = {3, 4, 5};
  std::vector<SetDistances> apart = {{data.d[0].data(), first.data(), 3},
                                     {data.d[1].data(), second.data(), 3}};
  EXPECT_THROW(RunMethod(ParseMethod("union_nn", kNames), apart, 6, {}), std::invalid_argument);
  std::vector<SetDistances> groups = data.views;
  groups[1].group = 1;
  EXPECT_THROW(RunMethod(ParseMethod("union_nn", kNames), groups, 60, {}), std::invalid_argument);
}

TEST(Methods, TheJointMethodsAreBayesOnTheirRepresentation) {
  Data data(50, 8);
  const std::vector<float> joint_values = testing::RandomDistances(50, 99);
  for (const char* name : {"mean_descriptor", "subspace", "discriminant"}) {
    const Method m = ParseMethod(name, kNames);
    EXPECT_TRUE(m.IsBayesian());
    EXPECT_EQ(m.Name(), name);
    const JointKind kind = *m.JointNeeded({});
    EXPECT_EQ(ToString(kind), name);
    // Without the representation: refused, naming what is missing.
    try {
      RunMethod(m, data.views, 50, {});
      FAIL() << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("not built"), std::string::npos) << e.what();
    }
    std::vector<JointDistances> joint = {{kind, {joint_values.data(), nullptr, 50}}};
    const PlaceBelief b = RunMethod(m, data.views, 50, {}, nullptr, nullptr, &joint);
    std::vector<SetDistances> one = {joint[0].distances};
    PlaceBelief expected;
    FuseBayes(one, {0}, 50, {}, nullptr, &expected);
    EXPECT_EQ(b.match, expected.match);
    EXPECT_DOUBLE_EQ(b.confidence, expected.confidence);
    MethodOptions places_only;  // the confidence among the places alone, as RunMethod's
    places_only.off_map.enabled = false;
    EXPECT_EQ(Decided(m, data.views, 50, places_only, &joint).accepted,
              expected.confidence > MethodOptions().decision.threshold.LogOdds());
    // +filter carries its posterior; the threshold gates it as it gates bayes:.
    MethodOptions strict;
    strict.decision.threshold.value = 0.999999;
    EXPECT_FALSE(Decided(m, data.views, 50, strict, &joint).accepted);
    EXPECT_NO_THROW(ParseMethod(std::string(name) + "+filter+seq", kNames));
  }
  // bsf asks for the joint representation of fusion_joint (adaptive only), and fuses the
  // sets alone without it.
  MethodOptions o;
  EXPECT_EQ(ParseMethod("bsf", kNames).JointNeeded(o), JointKind::kDiscriminant);
  o.fusion_joint = FusionJoint::kNone;
  EXPECT_FALSE(ParseMethod("bsf", kNames).JointNeeded(o));
  o.fusion_joint = FusionJoint::kMeanDescriptor;
  o.fusion = FusionRule::kProduct;
  EXPECT_FALSE(ParseMethod("bsf", kNames).JointNeeded(o));
  EXPECT_NO_THROW(RunMethod(ParseMethod("bsf", kNames), data.views, 50, {}));
  // "all" holds them only where asked (sets of one descriptor that share places).
  EXPECT_EQ(ParseMethodList("all", kNames).size(), 10u);
  EXPECT_EQ(ParseMethodList("all", kNames, true).size(), 14u);
}

}  // namespace
}  // namespace bsf_vpr
