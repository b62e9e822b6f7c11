// The rviz markers of the belief: the route as drawn, sizes relative to the route, and what each
// namespace draws.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "src/ros/view/belief_markers.h"

namespace bsf_vpr {
namespace {

using visualization_msgs::Marker;

ReferenceSets LineMap(int n, double spacing_m, bool with_poses) {
  ReferenceSet set = MakeReferenceSet("summer", RowMatrixXf::Random(n, 4));
  if (with_poses) {
    for (int k = 0; k < n; ++k) set.poses.push_back({k * spacing_m, 0, 0, 0});
  }
  ReferenceSets map;
  map.Add(std::move(set));
  return map;
}

// A belief over n places peaked at `peak` (posterior 0.9), the rest uniform.
Belief Peaked(int n, int peak, bool accepted) {
  Belief b;
  b.header.stamp = ros::Time(12, 5);
  b.method = "bsf";
  b.num_places = n;
  for (int k = 0; k < n; ++k) {
    b.place_ids.push_back(k);
    b.posterior.push_back(k == peak ? 0.9f : 0.1f / static_cast<float>(n - 1));
  }
  b.match = peak;
  b.confidence = std::log(0.9 / 0.1);
  b.accepted = accepted;
  b.set_names = {"summer", "fall"};
  b.selected_sets = {"summer"};
  b.set_weights = {1.0f, 0.0f};
  return b;
}

const Marker* Find(const visualization_msgs::MarkerArray& a, const std::string& ns, int id = 0) {
  for (const Marker& m : a.markers) {
    if (m.ns == ns && m.id == id && m.action == Marker::ADD) return &m;
  }
  return nullptr;
}

// The bar of LINE_LIST `bars` standing at x (metres), its height, or -1.
double BarHeightAt(const Marker& bars, double x, double tolerance) {
  double height = -1;
  for (size_t k = 0; k + 1 < bars.points.size(); k += 2) {
    if (std::abs(bars.points[k].x - x) <= tolerance) {
      height = std::max(height, bars.points[k + 1].z - bars.points[k].z);
    }
  }
  return height;
}

TEST(RouteDrawing, WithoutPosesTheRouteFillsTheView) {
  BeliefViewOptions options;  // view 100 m, spacing 0
  for (int n : {2, 100, 1500}) {
    const RouteDrawing route = MakeRouteDrawing(LineMap(n, 0, false), options);
    ASSERT_EQ(route.points.size(), static_cast<size_t>(n));
    EXPECT_FALSE(route.from_poses);
    EXPECT_NEAR(route.extent_m, 100.0, 1e-9) << n;
    EXPECT_NEAR(route.spacing_m, 100.0 / (n - 1), 1e-12);
    EXPECT_TRUE(route.fits_view);
    EXPECT_DOUBLE_EQ(route.scale_m, route.extent_m);
    EXPECT_NEAR(route.centre.x(), 50.0, 1e-9);
    // The view frame stays on the route's centre wherever the match is.
    EXPECT_EQ(ViewFocus(route), route.centre);
  }
}

// A route larger than the view is shrunk to fit it, about its centre: every place is in
// view (the view used to follow the match at full size, showing about 12 of the 100 places
// of the README's 1000 m robot map).
TEST(RouteDrawing, ARouteLargerThanTheViewIsShrunkToFitIt) {
  BeliefViewOptions options;
  options.marker_spacing_m = 1.0;  // 1500 places, 1499 m
  const RouteDrawing route = MakeRouteDrawing(LineMap(1500, 0, false), options);
  EXPECT_NEAR(route.extent_m, 1499.0, 1e-9);
  EXPECT_FALSE(route.fits_view);
  EXPECT_DOUBLE_EQ(route.scale_m, 100.0);
  EXPECT_NEAR(route.draw_scale, 100.0 / 1499, 1e-12);
  EXPECT_NEAR(route.spacing_m, 100.0 / 1499, 1e-12);
  EXPECT_NEAR(route.points.front().x(), route.centre.x() - 50, 1e-9);
  EXPECT_NEAR(route.points.back().x(), route.centre.x() + 50, 1e-9);
  EXPECT_EQ(ViewFocus(route), route.centre);
}

TEST(BeliefMarkers, TheReadmeRobotMapShowsEveryBarTheLegendAndPlaceNumbers) {
  BeliefViewOptions options;  // the shipped view: 100 m
  const RouteDrawing route = MakeRouteDrawing(LineMap(100, 10.0, true), options);  // 990 m
  ASSERT_FALSE(route.fits_view);
  Belief belief = Peaked(100, 63, true);
  for (float& p : belief.posterior) p = std::max(p, 0.01f);  // every bar drawn
  const auto markers = MakeBeliefMarkers(route, belief, {63}, true, options);
  const Marker* bars = Find(markers, "belief");
  ASSERT_NE(bars, nullptr);
  ASSERT_EQ(bars->points.size(), 200u);  // one bar per place
  const MarkerSizes size = SizesFor(route, 1);
  for (const auto& p : bars->points) {  // all within the view around the view frame
    EXPECT_LE(std::abs(p.x - ViewFocus(route).x()), 50 + 1e-9);
  }
  // Bars as wide as most of the drawn spacing, not overlapping.
  EXPECT_GT(size.bar_width_m, 0.5 * route.spacing_m);
  EXPECT_LT(size.bar_width_m, route.spacing_m);
  const Marker* legend = Find(markers, "legend");
  ASSERT_NE(legend, nullptr);
  EXPECT_NE(legend->text.find("bars: P(place)"), std::string::npos) << legend->text;
  EXPECT_NE(legend->text.find("route 990 m drawn 9.9 times smaller"), std::string::npos)
      << legend->text;
  // Every 10th place numbered, beside it; 0 and 99 by the legend.
  EXPECT_EQ(Find(markers, "legend", 1)->text, "0");
  EXPECT_EQ(Find(markers, "legend", 2)->text, "99");
  for (int k = 0; k < 9; ++k) {
    const Marker* number = Find(markers, "place_numbers", k);
    ASSERT_NE(number, nullptr) << k;
    EXPECT_EQ(number->text, std::to_string(10 * (k + 1)));
    EXPECT_NEAR(number->pose.position.x, route.points[10 * (k + 1)].x(), 1e-9);
  }
  EXPECT_EQ(Find(markers, "place_numbers", 9), nullptr);
  // A route that fits is drawn at its true positions.
  const RouteDrawing small = MakeRouteDrawing(LineMap(10, 10.0, true), options);
  EXPECT_DOUBLE_EQ(small.draw_scale, 1.0);
  EXPECT_EQ(small.points[7], Eigen::Vector3d(70, 0, 0));
  const auto few = MakeBeliefMarkers(small, Peaked(10, 3, true), {}, true, options);
  EXPECT_EQ(Find(few, "legend")->text.find("smaller"), std::string::npos);
}

TEST(PlaceNumberStep, IsOneTwoOrFiveTimesAPowerOfTenAndNumbersAboutTenPlaces) {
  EXPECT_EQ(PlaceNumberStep(1), 1);
  EXPECT_EQ(PlaceNumberStep(11), 1);
  EXPECT_EQ(PlaceNumberStep(12), 2);
  EXPECT_EQ(PlaceNumberStep(100), 10);
  EXPECT_EQ(PlaceNumberStep(1500), 200);
  EXPECT_EQ(PlaceNumberStep(100000), 10000);
  for (int n : {2, 7, 30, 101, 999, 4321, 1000000}) {
    EXPECT_LE((n - 1) / PlaceNumberStep(n), kPlaceNumbers) << n;
  }
}

TEST(RouteDrawing, PlacePosesAreUsedWhenEveryPlaceHasOne) {
  BeliefViewOptions options;
  options.marker_spacing_m = 3.0;  // not used: the places have poses
  const RouteDrawing small = MakeRouteDrawing(LineMap(6, 10.0, true), options);
  EXPECT_TRUE(small.from_poses);
  EXPECT_EQ(small.points[4], Eigen::Vector3d(40, 0, 0));
  EXPECT_DOUBLE_EQ(small.spacing_m, 10.0);
  EXPECT_DOUBLE_EQ(small.extent_m, 50.0);
  EXPECT_DOUBLE_EQ(small.scale_m, 50.0);  // sized for the route, smaller than the view
  const RouteDrawing large = MakeRouteDrawing(LineMap(100, 10.0, true), options);
  EXPECT_DOUBLE_EQ(large.scale_m, 100.0);
  // A map where some places have no pose is laid out on the line.
  ReferenceSets mixed = LineMap(6, 10.0, true);
  ReferenceSet more = MakeReferenceSet("fall", RowMatrixXf::Random(8, 4));
  mixed.Add(std::move(more));  // places 6 and 7 have no pose
  EXPECT_FALSE(MakeRouteDrawing(mixed, options).from_poses);
}

TEST(MarkerSizes, FollowTheRouteExtentNotFixedMetres) {
  BeliefViewOptions options;
  const RouteDrawing a = MakeRouteDrawing(LineMap(26, 1.0, true), options);  // 25 m
  const RouteDrawing b = MakeRouteDrawing(LineMap(26, 2.0, true), options);  // 50 m
  const MarkerSizes sa = SizesFor(a, 1), sb = SizesFor(b, 1);
  EXPECT_DOUBLE_EQ(sb.bar_height_m, 2 * sa.bar_height_m);
  EXPECT_DOUBLE_EQ(sb.bar_width_m, 2 * sa.bar_width_m);
  EXPECT_DOUBLE_EQ(sb.pin_diameter_m, 2 * sa.pin_diameter_m);
  EXPECT_DOUBLE_EQ(sb.label_height_m, 2 * sa.label_height_m);
  EXPECT_DOUBLE_EQ(sa.bar_height_m, 0.3 * 25);
  // The shipped view shows about view_size_m across 1200 pixels: every mark of the 1500-place
  // Nordland route is at least 3 pixels wide and the label at least 30 pixels tall there.
  const RouteDrawing nordland = MakeRouteDrawing(LineMap(1500, 0, false), options);
  const MarkerSizes s = SizesFor(nordland, 1);
  const double pixel_m = 100.0 / 1200;
  EXPECT_GE(s.bar_width_m, 3 * pixel_m);
  EXPECT_GE(s.pin_diameter_m, 3 * pixel_m);
  EXPECT_GE(s.label_height_m, 30 * pixel_m);
  EXPECT_LE(s.bar_height_m, 0.5 * nordland.extent_m);
}

TEST(BeliefMarkers, DrawTheBeliefTheMatchTheTruthAndTheLabel) {
  BeliefViewOptions options;
  options.map_frame = "world";
  const RouteDrawing route = MakeRouteDrawing(LineMap(1500, 0, false), options);
  const Belief belief = Peaked(1500, 700, true);
  const auto markers = MakeBeliefMarkers(route, belief, {702}, true, options);
  ASSERT_FALSE(markers.markers.empty());
  EXPECT_EQ(markers.markers[0].action, Marker::DELETEALL);  // nothing stale stays drawn
  for (size_t k = 1; k < markers.markers.size(); ++k) {
    EXPECT_EQ(markers.markers[k].header.frame_id, "world");
    EXPECT_EQ(markers.markers[k].header.stamp, belief.header.stamp);
  }
  const MarkerSizes size = SizesFor(route, 1);
  const double x700 = route.points[700].x();
  const Marker* bars = Find(markers, "belief");
  ASSERT_NE(bars, nullptr);
  EXPECT_EQ(bars->type, Marker::LINE_LIST);
  EXPECT_NEAR(BarHeightAt(*bars, x700, 1e-9), size.bar_height_m, 1e-9);
  // The other places hold 1/13500 of the peak's mass: not drawn on the linear scale.
  EXPECT_EQ(bars->points.size(), 2u);
  const Marker* pin = Find(markers, "match");
  ASSERT_NE(pin, nullptr);
  EXPECT_NEAR(pin->pose.position.x, x700, 1e-9);
  EXPECT_GT(pin->color.g, 0.8f);  // green: accepted
  EXPECT_LT(pin->color.r, 0.5f);
  const Marker* truth = Find(markers, "true_places");
  ASSERT_NE(truth, nullptr);
  ASSERT_EQ(truth->points.size(), 1u);
  EXPECT_NEAR(truth->points[0].x, route.points[702].x(), 1e-9);
  const Marker* label = Find(markers, "label");
  ASSERT_NE(label, nullptr);
  EXPECT_EQ(label->type, Marker::TEXT_VIEW_FACING);
  for (const char* part : {"place 700 of 1500", "ACCEPTED", "p 0.900", "selected: summer"}) {
    EXPECT_NE(label->text.find(part), std::string::npos) << part << " in " << label->text;
  }
  EXPECT_GT(label->pose.position.z, pin->scale.z);  // above the pin
  EXPECT_NE(Find(markers, "legend"), nullptr);

  const auto rejected = MakeBeliefMarkers(route, Peaked(1500, 700, false), {}, true, options);
  EXPECT_GT(Find(rejected, "match")->color.r, 0.9f);  // orange: not accepted
  EXPECT_NE(Find(rejected, "label")->text.find("not accepted"), std::string::npos);
  EXPECT_EQ(Find(rejected, "label")->text.find("OFF THE MAP"), std::string::npos);
  EXPECT_EQ(Find(rejected, "label")->text.find("no place of the map"), std::string::npos);
  EXPECT_EQ(Find(rejected, "true_places"), nullptr);
  // A belief that the robot is off the map says so.
  Belief lost = Peaked(1500, 700, false);
  lost.off_map_probability = 0.97;
  const std::string text = Find(MakeBeliefMarkers(route, lost, {}, true, options), "label")->text;
  EXPECT_NE(text.find("not accepted, OFF THE MAP"), std::string::npos) << text;
  EXPECT_NE(text.find("no place of the map: p 0.970"), std::string::npos) << text;
}

TEST(BeliefMarkers, TheLabelStaysInsideTheViewAtTheEndsOfTheRoute) {
  BeliefViewOptions options;
  const RouteDrawing route = MakeRouteDrawing(LineMap(100, 0.9, true), options);  // 89 m: fits
  ASSERT_TRUE(route.fits_view);
  const MarkerSizes size = SizesFor(route, 1);
  for (int match : {0, 99}) {
    const Belief belief = Peaked(100, match, true);
    const auto markers = MakeBeliefMarkers(route, belief, {}, true, options);
    const Marker* label = Find(markers, "label");
    ASSERT_NE(label, nullptr);
    size_t longest = 0;
    for (const std::string& line : BeliefLabelLines(belief, true))
      longest = std::max(longest, line.size());
    const double half_text = 0.3 * size.label_height_m * static_cast<double>(longest);
    // Its whole width within the view around the route's centre; it was centred on the end.
    EXPECT_LE(label->pose.position.x + half_text,
              route.centre.x() + options.view_size_m / 2 + 1e-9);
    EXPECT_GE(label->pose.position.x - half_text,
              route.centre.x() - options.view_size_m / 2 - 1e-9);
    EXPECT_NE(label->pose.position.x, route.points[static_cast<size_t>(match)].x()) << match;
  }
  // A match in the middle keeps its label above it.
  const auto middle = MakeBeliefMarkers(route, Peaked(100, 50, true), {}, true, options);
  EXPECT_NEAR(Find(middle, "label")->pose.position.x, route.points[50].x(), 1e-9);
}

TEST(BeliefMarkers, TheLogScaleShowsWhatTheLinearScaleHides) {
  BeliefViewOptions options;
  const RouteDrawing route = MakeRouteDrawing(LineMap(100, 0, false), options);
  Belief belief = Peaked(100, 40, true);
  ASSERT_FLOAT_EQ(belief.posterior[40], 0.9f);
  for (float& p : belief.posterior) p = p < 0.5f ? std::min(p, 1e-7f) : p;  // all but the peak
  belief.posterior[80] = 0.9e-3f;  // a second peak a thousandth of the first
  EXPECT_LT(BarHeightAt(*Find(MakeBeliefMarkers(route, belief, {}, true, options), "belief"),
                        route.points[80].x(), 1e-9),
            0);
  options.log_scale = true;
  const auto markers = MakeBeliefMarkers(route, belief, {}, true, options);
  const MarkerSizes size = SizesFor(route, 1);
  EXPECT_NEAR(BarHeightAt(*Find(markers, "belief"), route.points[80].x(), 1e-9),
              (1 - 3 / kLogDecades) * size.bar_height_m, 1e-6 * size.bar_height_m);
}

TEST(BeliefMarkers, LargeRoutesAreBinnedAndKeepTheirPeak) {
  BeliefViewOptions options;
  const int n = 100000;
  const RouteDrawing route = MakeRouteDrawing(LineMap(n, 0, false), options);
  Belief belief = Peaked(n, 61234, true);
  for (float& p : belief.posterior) p = std::max(p, 0.5f);  // everything drawn
  belief.posterior[61234] = 1.0f;
  const auto markers = MakeBeliefMarkers(route, belief, {}, true, options);
  const Marker* bars = Find(markers, "belief");
  EXPECT_LE(bars->points.size(), 2u * kMaxBars);
  EXPECT_GE(bars->points.size(), 2u * kMaxBars - 2);
  const MarkerSizes size = SizesFor(route, (n + kMaxBars - 1) / kMaxBars);
  EXPECT_NEAR(BarHeightAt(*bars, route.points[61234].x(), 1e-9), size.bar_height_m, 1e-9);
  // One route segment per bin, not per place.
  EXPECT_LE(Find(markers, "route")->points.size(), 2u * kMaxBars);
}

TEST(BeliefMarkers, DistanceMethodsAreDrawnByRank) {
  BeliefViewOptions options;
  const RouteDrawing route = MakeRouteDrawing(LineMap(50, 0, false), options);
  Belief belief;
  belief.method = "med";
  belief.num_places = 50;
  belief.place_ids = {7, 30, 2};
  belief.match = 7;
  belief.confidence = -0.25;
  const auto markers = MakeBeliefMarkers(route, belief, {}, false, options);
  const Marker* bars = Find(markers, "belief");
  const double best = BarHeightAt(*bars, route.points[7].x(), 1e-9);
  EXPECT_GT(best, BarHeightAt(*bars, route.points[30].x(), 1e-9));
  EXPECT_GT(BarHeightAt(*bars, route.points[30].x(), 1e-9),
            BarHeightAt(*bars, route.points[2].x(), 1e-9));
  EXPECT_NE(Find(markers, "label")->text.find("med: distance 0.25"), std::string::npos);
  EXPECT_NE(Find(markers, "legend")->text.find("rank"), std::string::npos);
}

TEST(BeliefLabel, ShowsTheWeightsOnlyWhenTheMethodGradedTheSets) {
  Belief belief = Peaked(10, 3, true);
  const auto plain = BeliefLabelLines(belief, true);
  EXPECT_EQ(plain.size(), 3u);
  belief.set_weights = {1.0f, 0.43f};
  const auto graded = BeliefLabelLines(belief, true);
  ASSERT_EQ(graded.size(), 4u);
  EXPECT_EQ(graded[3], "weights: summer 1.00, fall 0.43");
}

}  // namespace
}  // namespace bsf_vpr
