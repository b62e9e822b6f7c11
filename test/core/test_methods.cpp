#include <gtest/gtest.h>

#include <cmath>

#include "bsf_vpr/core/methods.h"
#include "test_util.h"

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
  FuseBayes(data.views, {0, 1}, 120, {}, nullptr, {}, 5, &with, &s.set_stats);
  FuseBayes(data.views, {0, 1}, 120, {}, nullptr, {}, 5, &without);
  EXPECT_TRUE(with.log_posterior.isApprox(without.log_posterior));
  const std::vector<DistanceStats> short_stats(1);
  EXPECT_THROW(FuseBayes(data.views, {0}, 120, {}, nullptr, {}, 5, &with, &short_stats),
               std::invalid_argument);
}

TEST(Methods, BsfWithLargeGammaIsBayesFullAndWithZeroGammaTheBestSetAlone) {
  Data data(150, 9);
  MethodOptions wide;
  wide.selection.gamma_fraction = 1e9;
  const PlaceBelief all = RunMethod(ParseMethod("bsf", kNames), data.views, 150, wide);
  const PlaceBelief full = RunMethod(ParseMethod("bayes_full", kNames), data.views, 150, {});
  EXPECT_EQ(all.match, full.match);
  EXPECT_TRUE(all.log_posterior.isApprox(full.log_posterior));

  MethodOptions narrow;
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
    const PlaceBelief strict = RunMethod(m, data.views, 100, {});  // default 0
    EXPECT_FALSE(strict.accepted) << name;
    const double distance = -strict.confidence;
    MethodOptions o;
    o.max_match_distance = distance;  // exactly the match's distance: accepted
    EXPECT_TRUE(RunMethod(m, data.views, 100, o).accepted) << name;
    o.max_match_distance = distance * 0.999;
    EXPECT_FALSE(RunMethod(m, data.views, 100, o).accepted) << name;
  }
  MethodOptions bad;
  bad.max_match_distance = -1;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad.max_match_distance = NAN;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

TEST(Methods, ANanDistanceNeverGivesAnAcceptedBelief) {
  Data data(50, 6);
  data.d[0][7] = NAN;
  data.d[1][7] = NAN;
  data.d[2][7] = NAN;
  MethodOptions o;
  o.threshold = Threshold{Threshold::Kind::kLogOdds, -1000};
  try {
    const PlaceBelief b = RunMethod(ParseMethod("bayes_full", kNames), data.views, 50, o);
    EXPECT_FALSE(b.log_posterior.hasNaN());
    EXPECT_FALSE(std::isnan(b.confidence));
  } catch (const std::invalid_argument&) {
    // Refusing the query is as good: nothing is published.
  }
}

}  // namespace
}  // namespace bsf_vpr
