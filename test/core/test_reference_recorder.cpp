#include <gtest/gtest.h>

#include <cmath>

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
  EXPECT_THROW(rec.Add(Eigen::VectorXf::Zero(4)), std::invalid_argument);  // no information
  // A broken pose of the robot is refused with its descriptor (its NaN would be the place's).
  for (const PlacePose& bad :
       {PlacePose{NAN, 0, 0, 0}, PlacePose{0, 0, 1e12, 0}, PlacePose{0, 0, 0, -INFINITY}}) {
    EXPECT_THROW(rec.Add(Eigen::VectorXf::Ones(4), bad), std::invalid_argument);
  }
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

// Descriptor k of a recording holds the value k first: a row says which it was. The ones
// after it keep descriptor 0 from being all zeros (refused: it carries no information).
Eigen::VectorXf Numbered(int k) {
  Eigen::VectorXf d = Eigen::VectorXf::Ones(4);
  d(0) = static_cast<float>(k);
  return d;
}

// A map of 20 places one metre apart along x, heading east.
ReferenceRecorder::Map StraightMap() {
  ReferenceRecorder::Map map;
  for (int i = 0; i < 20; ++i) map.place_poses.push_back(PlacePose{double(i), 0, 0, 0});
  map.options.association_radius_m = 0.6;
  return map;
}

TEST(ReferenceRecorder, ByPoseAssociatesWithTheMapsPlaces) {
  // Synthetic drive: 0..10 m at 0.25 m per descriptor, a stop of 20 descriptors, then
  // 10..15 m at 0.5 m per descriptor, 0.2 m beside the mapped route.
  ReferenceRecorder rec;
  rec.Start("tonight", "night", 4, RecordingPlaces::kPose);
  EXPECT_THROW(rec.Add(Numbered(0)), std::invalid_argument);  // no pose: not recorded
  std::vector<double> xs;
  for (int i = 0; i <= 40; ++i) xs.push_back(0.25 * i);
  for (int i = 0; i < 20; ++i) xs.push_back(10);
  for (int i = 1; i <= 10; ++i) xs.push_back(10 + 0.5 * i);
  for (size_t k = 0; k < xs.size(); ++k) {
    rec.Add(Numbered(static_cast<int>(k)), PlacePose{xs[k], 0.2, 0, 0});
  }
  const ReferenceSet s = rec.Build("t", StraightMap());
  ASSERT_EQ(s.place_ids.size(), 16u);  // places 0..15; 16..19 not driven
  for (size_t k = 0; k < s.place_ids.size(); ++k) {
    EXPECT_EQ(s.place_ids[k], static_cast<int>(k));
    const int row = static_cast<int>(s.descriptors(static_cast<Eigen::Index>(k), 0));
    EXPECT_NEAR(xs[static_cast<size_t>(row)], static_cast<double>(k), 1e-9);  // nearest one
    EXPECT_NEAR(s.poses[k].x_m, static_cast<double>(k), 1e-9);
    EXPECT_NEAR(s.poses[k].y_m, 0.2, 1e-12);  // where it was seen
  }
  EXPECT_EQ(s.name, "tonight");
  EXPECT_EQ(s.descriptor_type, "t");
  // Which recorded descriptor each row holds (the k-th Add holds Numbered(k)).
  std::vector<int> source;
  const ReferenceSet again = rec.Build("t", StraightMap(), &source);
  ASSERT_EQ(source.size(), again.place_ids.size());
  for (size_t k = 0; k < source.size(); ++k) {
    EXPECT_EQ(source[k], static_cast<int>(again.descriptors(static_cast<Eigen::Index>(k), 0)));
  }
  // Off the route (30 m north): nothing to associate; the recording stays.
  ReferenceRecorder off;
  off.Start("lost", "", 4, RecordingPlaces::kPose);
  off.Add(Numbered(0), PlacePose{3, 30, 0, 0});
  try {
    off.Build("", StraightMap());
    ADD_FAILURE() << "built a set off the map";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("none of its 1 descriptors lies within 0.6"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(off.recording());
  // On a map without poses the traversal makes its own places, after the map's.
  ReferenceRecorder::Map unposed;
  unposed.place_poses.resize(100);
  const ReferenceSet own = rec.Build("", unposed);
  EXPECT_EQ(own.place_ids.front(), 100);
  EXPECT_EQ(own.place_ids.size(), 16u);
}

TEST(ReferenceRecorder, LocalizedKeepsTheMostConfidentDescriptorOfEachPlace) {
  ReferenceRecorder rec;
  rec.Start("tonight", "", 4, RecordingPlaces::kLocalized);
  EXPECT_THROW(rec.Add(Numbered(0), PlacePose{}), std::invalid_argument);  // not localised
  rec.Add(Numbered(1), std::nullopt, LocalizedPlace{7, 2.0});
  rec.Add(Numbered(2), std::nullopt, LocalizedPlace{3, 1.0});
  rec.Add(Numbered(3), std::nullopt, LocalizedPlace{3, 5.0});
  rec.Add(Numbered(4), std::nullopt, LocalizedPlace{3, 4.0});
  const ReferenceSet s = rec.Build("", StraightMap());
  EXPECT_EQ(s.place_ids, (std::vector<int>{3, 7}));
  EXPECT_FLOAT_EQ(s.descriptors(0, 0), 3.0f);
  EXPECT_FLOAT_EQ(s.descriptors(1, 0), 1.0f);
  ASSERT_EQ(s.poses.size(), 2u);  // the map's poses of the places
  EXPECT_EQ(s.poses[1].x_m, 7.0);
  EXPECT_TRUE(rec.Build("", {}).poses.empty());  // a map without poses: none
  std::vector<int> source;
  rec.Build("", {}, &source);
  EXPECT_EQ(source, (std::vector<int>{2, 0}));  // the third and the first descriptor added
  EXPECT_EQ(ParseRecordingPlaces("localized"), RecordingPlaces::kLocalized);
  EXPECT_EQ(ToString(RecordingPlaces::kPose), "pose");
  EXPECT_THROW(ParseRecordingPlaces("gps"), std::invalid_argument);
}

}  // namespace
}  // namespace bsf_vpr
