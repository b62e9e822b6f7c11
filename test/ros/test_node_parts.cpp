// The fusion node's parts that need no master: selection counters and enumerations parsed
// from parameters.
#include <gtest/gtest.h>

#include "../../src/ros/odometry_tracker.h"
#include "../../src/ros/selection_counters.h"

namespace bsf_vpr {
namespace {

ReferenceMap ThreeSets() {
  ReferenceMap map;
  for (const char* name : {"summer", "fall", "winter"}) {
    map.Add(MakeReferenceSet(name, RowMatrixXf::Random(4, 3)));
  }
  return map;
}

TEST(SelectionCounters, CountSelectedBestAndSuppliedPerSet) {
  const ReferenceMap map = ThreeSets();
  SelectionCounters c;
  Recognition r;
  r.belief.selection.selected = {0, 2};
  r.belief.selection.best = 2;
  r.closest_set = 0;
  c.Count(r, map);
  r.belief.selection.selected = {2};
  r.closest_set = 2;
  c.Count(r, map);
  EXPECT_EQ(c.queries(), 2);
  const ReferenceSetUsage winter = c.Usage("winter");
  EXPECT_EQ(winter.selected, 2);
  EXPECT_EQ(winter.best, 2);
  EXPECT_EQ(winter.supplied_match, 1);
  EXPECT_DOUBLE_EQ(winter.selected_fraction, 1.0);
  EXPECT_EQ(c.Usage("summer").selected, 1);
  EXPECT_EQ(c.Usage("fall").selected, 0);
  c.Forget("winter");
  EXPECT_EQ(c.Usage("winter").selected, 0);
  EXPECT_EQ(c.queries(), 2);
  c.Reset();
  EXPECT_EQ(c.queries(), 0);
  EXPECT_EQ(c.Usage("summer").selected_fraction, 0.0);
}

TEST(OdometrySource, ParsesOnceAndNamesTheChoices) {
  for (const char* name : {"none", "topic", "tf"}) {
    EXPECT_EQ(ToString(ParseOdometrySource(name)), name);
  }
  try {
    ParseOdometrySource("gps");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("none, topic or tf"), std::string::npos);
  }
}

}  // namespace
}  // namespace bsf_vpr
