#include <gtest/gtest.h>

#include "bsf_vpr/evaluation/curation.h"

namespace bsf_vpr {
namespace {

// Sets: summer (usually closest), dusk (always selected with a closer summer), night (never
// selected). Queries 21..25 are far from every set: a coverage gap.
std::vector<QueryRecord> Records() {
  std::vector<QueryRecord> r;
  for (int q = 0; q < 40; ++q) {
    QueryRecord x;
    x.set_names = {"summer", "dusk", "night"};
    const float scale = (q >= 21 && q < 26) ? 3.0f : 1.0f;
    x.set_min_distances = {1.0f * scale, 1.02f * scale, 2.0f * scale};
    x.selected = {"summer", "dusk"};
    if (q % 10 == 0) {  // now and then dusk is the closest, alone
      x.set_min_distances = {1.2f, 1.0f, 2.0f};
      x.selected = {"dusk"};
    }
    r.push_back(x);
  }
  return r;
}

TEST(Curation, FindsRarelySelectedAndDominatedSetsAndCoverageGaps) {
  CurationOptions o;
  o.dominated_fraction = 0.85;
  const CurationReport rep = Curate(Records(), o);
  ASSERT_EQ(rep.sets.size(), 3u);
  EXPECT_FALSE(rep.sets[0].redundant) << rep.sets[0].reason;  // summer
  EXPECT_NEAR(rep.sets[0].selected_fraction, 36.0 / 40, 1e-12);
  EXPECT_NEAR(rep.sets[0].best_fraction, 36.0 / 40, 1e-12);
  EXPECT_TRUE(rep.sets[1].redundant);  // dusk: 36 of its 40 selections with a closer summer
  EXPECT_EQ(rep.sets[1].dominated_by, "summer");
  EXPECT_TRUE(rep.sets[2].redundant);  // night: never selected
  EXPECT_EQ(rep.sets[2].reason, "rarely selected");
  ASSERT_EQ(rep.gaps.size(), 1u);
  EXPECT_EQ(rep.gaps[0].first_query, 21);
  EXPECT_EQ(rep.gaps[0].last_query, 25);
  EXPECT_NEAR(rep.gaps[0].worst_ratio, 3.0, 1e-6);
  const std::string table = FormatCurationReport(rep);
  EXPECT_NE(table.find("queries 21-25"), std::string::npos) << table;
  EXPECT_NE(table.find("redundant: always selected with the closer 'summer'"), std::string::npos)
      << table;
  // A stricter dominance threshold keeps dusk (it stands alone in 4 of 40 queries).
  o.dominated_fraction = 0.95;
  EXPECT_FALSE(Curate(Records(), o).sets[1].redundant);
}

TEST(Curation, ReportsTheMeanWeightOfEachSetWhenTheBeliefsCarryIt) {
  std::vector<QueryRecord> records = Records();
  EXPECT_EQ(Curate(records, {}).sets[0].mean_weight, -1);  // not recorded: not shown
  EXPECT_EQ(FormatCurationReport(Curate(records, {})).find("weight"), std::string::npos);
  for (size_t q = 0; q < records.size(); ++q) {
    records[q].set_weights = {1.0f, q % 2 ? 0.5f : 0.25f, 0.0f};
  }
  const CurationReport rep = Curate(records, {});
  EXPECT_NEAR(rep.sets[0].mean_weight, 1.0, 1e-12);
  EXPECT_NEAR(rep.sets[1].mean_weight, 0.375, 1e-12);
  EXPECT_NEAR(rep.sets[2].mean_weight, 0.0, 1e-12);
  const std::string table = FormatCurationReport(rep);
  EXPECT_NE(table.find("weight"), std::string::npos) << table;
  EXPECT_NE(table.find(" 0.375"), std::string::npos) << table;
  records[3].set_weights.clear();  // one belief without weights: the mean is unknown
  EXPECT_EQ(Curate(records, {}).sets[1].mean_weight, -1);
}

TEST(Curation, RefusesInconsistentRecordsAndBadOptions) {
  EXPECT_THROW(Curate({}, {}), std::invalid_argument);
  std::vector<QueryRecord> r = Records();
  r[3].set_names = {"summer"};
  r[3].set_min_distances = {1.0f};
  EXPECT_THROW(Curate(r, {}), std::invalid_argument);
  CurationOptions o;
  o.gap_factor = 0.5;
  EXPECT_THROW(Curate(Records(), o), std::invalid_argument);
}

}  // namespace
}  // namespace bsf_vpr
