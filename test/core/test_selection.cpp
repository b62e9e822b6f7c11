#include <gtest/gtest.h>

#include <algorithm>

#include "bsf_vpr/core/selection.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

std::vector<SetDistances> Views(const std::vector<std::vector<float>>& d) {
  std::vector<SetDistances> v;
  for (const auto& x : d) v.push_back({x.data(), nullptr, static_cast<int>(x.size())});
  return v;
}

TEST(Selection, ContainsTheBestSetAndRespectsGammaAsInThePaper) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> gammas(0.0, 0.3);
  for (int trial = 0; trial < 200; ++trial) {
    const int m = 1 + trial % 6;
    std::vector<std::vector<float>> d;
    for (int u = 0; u < m; ++u) d.push_back(testing::RandomDistances(40, 1000 * trial + u));
    SelectionOptions opt;
    opt.gamma_fraction = gammas(rng);
    const Selection s = SelectReferenceSets(Views(d), opt);
    // Oracle: Eq. best_reference and reference_selection with the division.
    std::vector<float> mins;
    for (const auto& x : d) mins.push_back(*std::min_element(x.begin(), x.end()));
    const int best = static_cast<int>(std::min_element(mins.begin(), mins.end()) - mins.begin());
    ASSERT_EQ(s.best, best);
    ASSERT_TRUE(std::count(s.selected.begin(), s.selected.end(), best));
    for (int u = 0; u < m; ++u) {
      const bool expected = (mins[u] - mins[best]) / mins[best] <= opt.gamma_fraction;
      const bool got = std::count(s.selected.begin(), s.selected.end(), u) > 0;
      EXPECT_EQ(got, expected) << "trial " << trial << " set " << u;
      EXPECT_FLOAT_EQ(s.set_stats[u].min, mins[u]);
    }
  }
}

TEST(Selection, ZeroMinimumDistanceDoesNotDivideByZero) {
  const std::vector<std::vector<float>> d = {{0.0f, 1.0f}, {0.0f, 3.0f}, {0.1f, 2.0f}};
  const Selection s = SelectReferenceSets(Views(d), {});
  EXPECT_EQ(s.best, 0);
  EXPECT_EQ(s.selected, (std::vector<int>{0, 1}));
}

TEST(Selection, StandardizedRuleIsScaleFree) {
  // Set 1 is set 0 scaled by 1000 (another descriptor type): same standardized score.
  std::vector<float> a = testing::RandomDistances(100, 3);
  a[5] = 0.1f;
  std::vector<float> b = a;
  for (float& v : b) v *= 1000.0f;
  std::vector<float> c = testing::RandomDistances(100, 4);  // no distinctive minimum
  SelectionOptions opt;
  opt.rule = SelectionRule::kStandardized;
  opt.gamma_fraction = 0.01;
  const Selection s = SelectReferenceSets(Views({c, b, a}), opt);
  EXPECT_TRUE(s.best == 1 || s.best == 2);
  EXPECT_EQ(s.selected, (std::vector<int>{1, 2}));
  // The relative rule is dominated by scale: the scaled set is never selected.
  const Selection r = SelectReferenceSets(Views({c, b, a}), {});
  EXPECT_EQ(std::count(r.selected.begin(), r.selected.end(), 1), 0);
}

TEST(Selection, StandardizedRuleSurvivesZeroVariance) {
  const std::vector<std::vector<float>> d = {{1.0f, 1.0f, 1.0f}, {2.0f, 2.0f, 2.0f}};
  SelectionOptions opt;
  opt.rule = SelectionRule::kStandardized;
  const Selection s = SelectReferenceSets(Views(d), opt);
  EXPECT_EQ(s.selected.size(), 2u);
}

TEST(Selection, RefusesBadInput) {
  EXPECT_THROW(SelectReferenceSets({}, {}), std::invalid_argument);
  SelectionOptions opt;
  opt.gamma_fraction = -0.1;
  try {
    opt.Validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("gamma_fraction"), std::string::npos);
  }
  EXPECT_THROW(ParseSelectionRule("absolute"), std::invalid_argument);
}

}  // namespace
}  // namespace bsf_vpr
