#include <gtest/gtest.h>

#include "bsf_vpr/core/reference_recorder.h"

namespace bsf_vpr {
namespace {

TEST(ReferenceRecorder, RecordsDescriptorsAsPlacesInOrder) {
  ReferenceRecorder rec;
  EXPECT_THROW(rec.Add(Eigen::VectorXf::Ones(4)), std::invalid_argument);
  EXPECT_THROW(rec.Finish(), std::invalid_argument);
  rec.Start("today", "rain", 0);
  EXPECT_THROW(rec.Start("other", "", 0), std::invalid_argument);
  EXPECT_THROW(rec.Finish(), std::invalid_argument);  // nothing recorded yet
  EXPECT_TRUE(rec.recording());
  rec.Add(Eigen::VectorXf::Constant(4, 1.0f), PlacePose{1, 0, 0, 0});
  rec.Add(Eigen::VectorXf::Constant(4, 2.0f), PlacePose{2, 0, 0, 0});
  EXPECT_THROW(rec.Add(Eigen::VectorXf::Ones(5)), std::invalid_argument);
  EXPECT_EQ(rec.count(), 2);
  // Build leaves the recording running (a failed save must lose nothing).
  EXPECT_EQ(rec.Build("test_4").size(), 2);
  EXPECT_TRUE(rec.recording());
  EXPECT_EQ(rec.count(), 2);
  EXPECT_THROW(rec.Add(Eigen::VectorXf::Constant(4, 3.0e38f)), std::invalid_argument);
  const ReferenceSet s = rec.Finish("test_4");
  EXPECT_FALSE(rec.recording());
  EXPECT_EQ(s.name, "today");
  EXPECT_EQ(s.condition, "rain");
  EXPECT_EQ(s.place_ids, (std::vector<int>{0, 1}));
  EXPECT_FLOAT_EQ(s.descriptors(1, 3), 2.0f);
  ASSERT_EQ(s.poses.size(), 2u);
  rec.Start("partial", "", 4);
  rec.Add(Eigen::VectorXf::Ones(4), PlacePose{});
  rec.Add(Eigen::VectorXf::Ones(4));
  EXPECT_TRUE(rec.Finish().poses.empty());  // poses only when every descriptor had one
}

}  // namespace
}  // namespace bsf_vpr
