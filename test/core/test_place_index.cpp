// Places by position: traversals with stops, speed changes, a detour and a reversed
// stretch (synthetic trajectories: this tests the geometry, not recognition).
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "bsf_vpr/core/place_index.h"

namespace bsf_vpr {
namespace {

constexpr double kPi = 3.14159265358979323846;

PlacePose At(double x, double y, double yaw = 0) { return {x, y, 0, yaw}; }

// Along the x axis from 0 to `length` metres, `step` metres per frame, heading east.
std::vector<PlacePose> Straight(double length, double step) {
  std::vector<PlacePose> p;
  for (int i = 0; i * step <= length + 1e-9; ++i) p.push_back(At(i * step, 0));
  return p;
}

TEST(PlaceIndex, PlacesEveryMetreWhateverTheSpeed) {
  // 10 m at 0.25 m per frame, a stop of 40 frames, then 10 m at 0.5 m per frame.
  std::vector<PlacePose> route;
  for (int i = 0; i <= 40; ++i) route.push_back(At(0.25 * i, 0));
  for (int i = 0; i < 40; ++i) route.push_back(At(10, 0));
  for (int i = 1; i <= 20; ++i) route.push_back(At(10 + 0.5 * i, 0));
  PlaceIndexOptions o;
  const PlaceAssignment a = MakePlacesAlongRoute(route, o);
  ASSERT_EQ(a.place_ids.size(), 21u);  // 0, 1, ..., 20 m: the stop adds nothing
  for (size_t k = 0; k < a.place_ids.size(); ++k) {
    EXPECT_EQ(a.place_ids[k], static_cast<int>(k));
    EXPECT_NEAR(a.place_poses[k].x_m, static_cast<double>(k), 1e-9);
    EXPECT_NEAR(route[static_cast<size_t>(a.frames[k])].x_m, static_cast<double>(k), 1e-9);
  }
  EXPECT_EQ(a.new_places, 21);
  // Frames sparser than places: one place per frame, never the same frame twice.
  const PlaceAssignment sparse = MakePlacesAlongRoute(Straight(20, 2.5), o, 100);
  EXPECT_EQ(sparse.place_ids.size(), 9u);
  EXPECT_EQ(sparse.place_ids.front(), 100);
  EXPECT_EQ(std::set<int>(sparse.frames.begin(), sparse.frames.end()).size(), 9u);
}

TEST(PlaceIndex, AssociatesTheNearestFrameAndLeavesOthersUncovered) {
  std::vector<std::optional<PlacePose>> place_poses;
  for (const PlacePose& p : Straight(30, 1)) place_poses.push_back(p);
  // The second traversal is 0.4 m to the side, covers 5..20 m at 0.3 m per frame.
  std::vector<PlacePose> drive;
  for (int i = 0; i <= 50; ++i) drive.push_back(At(5 + 0.3 * i, 0.4));
  PlaceIndexOptions o;
  o.association_radius_m = 0.6;  // places 4 and 21 lie 1.08 m from the ends: not covered
  const PlaceAssignment a = AssociateWithPlaces(drive, place_poses, o);
  ASSERT_EQ(a.place_ids.front(), 5);
  ASSERT_EQ(a.place_ids.back(), 20);
  EXPECT_EQ(a.place_ids.size(), 16u);
  for (size_t k = 0; k < a.place_ids.size(); ++k) {
    EXPECT_LE(std::abs(drive[static_cast<size_t>(a.frames[k])].x_m - a.place_ids[k]), 0.15 + 1e-9);
    EXPECT_EQ(a.place_poses[k].x_m, drive[static_cast<size_t>(a.frames[k])].x_m);  // as seen
  }
  EXPECT_EQ(a.new_places, 0);
}

TEST(PlaceIndex, OppositeHeadingIsAnotherViewAndDetoursAddPlaces) {
  std::vector<std::optional<PlacePose>> place_poses;
  for (const PlacePose& p : Straight(20, 1)) place_poses.push_back(p);
  // East 0..10 m, a detour 30 m north for 10 m, back on the route, then west over 20..10 m.
  std::vector<PlacePose> drive;
  for (double x = 0; x <= 10; x += 0.5) drive.push_back(At(x, 0, 0));
  for (double x = 10; x <= 20; x += 0.5) drive.push_back(At(x, 30, 0));
  for (double x = 20; x >= 10; x -= 0.5) drive.push_back(At(x, 0, kPi));
  PlaceIndexOptions o;
  o.association_radius_m = 0.75;
  const PlaceAssignment kept = AssociateWithPlaces(drive, place_poses, o);
  // Only 0..10 m east: the westward stretch sees the places from behind.
  EXPECT_EQ(kept.place_ids.size(), 11u);
  EXPECT_EQ(kept.place_ids.back(), 10);
  o.add_new_places = true;
  const PlaceAssignment grown = AssociateWithPlaces(drive, place_poses, o);
  // + the detour (10 m: 11 places) + the westward stretch (10 m: 11 places), numbered after
  // the map's 21.
  EXPECT_EQ(grown.new_places, 22);
  EXPECT_EQ(grown.place_ids.size(), 33u);
  EXPECT_EQ(grown.place_ids[11], 21);
  EXPECT_NEAR(grown.place_poses[11].y_m, 30, 1e-9);
  EXPECT_NEAR(grown.place_poses.back().yaw_rad, kPi, 1e-9);
  o.max_yaw_difference_deg = 180;  // heading ignored: the westward stretch is the route
  EXPECT_EQ(AssociateWithPlaces(drive, place_poses, o).new_places, 11);
}

TEST(PlaceIndex, InterpolatesPosesAndHeadings) {
  PoseTrack track;
  track.stamps_s = {0, 1, 2, 10};
  track.poses = {At(0, 0, 3.0), At(2, 0, -3.0), At(2, 2, 0), At(0, 0, 0)};
  const std::optional<PlacePose> half = InterpolatePose(track, 0.5);
  ASSERT_TRUE(half);
  EXPECT_NEAR(half->x_m, 1, 1e-12);
  // From 3.0 to -3.0 rad the short way passes pi, not 0.
  EXPECT_NEAR(std::abs(half->yaw_rad), kPi, 1e-9);
  EXPECT_FALSE(InterpolatePose(track, -0.1));
  EXPECT_FALSE(InterpolatePose(track, 5));  // 8 s between samples: a gap
  EXPECT_TRUE(InterpolatePose(track, 5, 10));
  EXPECT_NEAR(InterpolatePose(track, 2)->y_m, 2, 1e-12);

  std::vector<PlacePose> path = {At(0, 0), At(0, 0), At(1, 1), At(1, 1), At(0, 2)};
  HeadingsFromPath(&path, 0.5);
  EXPECT_NEAR(path[0].yaw_rad, kPi / 4, 1e-12);
  EXPECT_NEAR(path[2].yaw_rad, 3 * kPi / 4, 1e-12);
  EXPECT_NEAR(path[4].yaw_rad, 3 * kPi / 4, 1e-12);  // the end keeps the last heading
}

TEST(PlaceIndex, LatLonToMetresAndConflicts) {
  // 0.001 degree of latitude is 111.2 m; of longitude at 60 N, half that.
  const PlacePose p = LocalMetresFromLatLon(60.001, 10.001, 60, 10);
  EXPECT_NEAR(p.y_m, 111.195, 0.01);
  EXPECT_NEAR(p.x_m, 55.6, 0.05);
  std::vector<std::optional<PlacePose>> a = {At(0, 0), At(1, 0), std::nullopt};
  std::vector<std::optional<PlacePose>> b = {At(0, 3), At(501, 0), At(2, 0)};
  const std::optional<PoseConflict> c = FindPoseConflict(a, b, 10);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->place, 1);
  EXPECT_NEAR(c->distance_m, 500, 1e-9);
  EXPECT_FALSE(FindPoseConflict(a, {At(0, 3)}, 10));
}

TEST(PlaceIndex, RefusesBadInput) {
  PlaceIndexOptions o;
  EXPECT_THROW(MakePlacesAlongRoute({}, o), std::invalid_argument);
  EXPECT_THROW(MakePlacesAlongRoute({At(0, NAN)}, o), std::invalid_argument);
  o.place_spacing_m = 0;
  EXPECT_THROW(MakePlacesAlongRoute({At(0, 0)}, o), std::invalid_argument);
}

}  // namespace
}  // namespace bsf_vpr
