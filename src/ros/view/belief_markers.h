// rviz markers that draw the belief along the route so that it reads at any route size.
//
// The route is every place of the map: at its pose when every place has one, else on a
// straight line along x (marker_spacing_m apart, or spread over view_size_m when that is 0).
// Everything is sized from the route's extent (the larger side of its bounding box), capped
// at view_size_m, the area the shipped rviz view shows: a 10 km route and a 100 m one both
// get bars, pins and text a viewer can read. A route larger than view_size_m is drawn
// shrunk about its centre to fit it (an overview: every place's bar in view; rviz cannot
// zoom its camera from a topic), the legend saying by how much; its markers then do not lie
// at the places' positions in map_frame (tf vpr_place does). Drawn (namespaces):
//   route       grey line through consecutive places (jumps of more than 5 spacings left out)
//   belief      a vertical bar per place, height and colour its posterior relative to the
//               best place (linear, or log10 over kLogDecades decades); distance methods,
//               which have no posterior, by rank. Places closer together than a bar's width
//               are binned (at most kMaxBars bars), each bin drawn at its best place.
//   match       a pin at the matched place: green when accepted, orange when not
//   true_places cyan spheres at the ground-truth places, when known
//   label       text above the pin: place, confidence, accepted or not, selected sets
//   legend      what the colours mean (and the shrink factor), the first and last place
//               numbers
//   place_numbers  the number of every k-th place (k 1, 2 or 5 times a power of ten; at
//               most about kPlaceNumbers of them)
// The view frame (view_frame, a tf child of map_frame) sits at the centre of the route as
// drawn, where the shipped rviz view looks.
#pragma once

#include <bsf_vpr/Belief.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/reference_set.h"
#include "src/ros/view/belief_view_options.h"

namespace bsf_vpr {

// Most bars drawn; larger routes are binned.
constexpr int kMaxBars = 2000;
// About how many places are numbered along the route.
constexpr int kPlaceNumbers = 10;

// The route as drawn, and the sizes derived from it.
struct RouteDrawing {
  std::vector<Eigen::Vector3d> points;  // one per place as drawn, in map_frame (metres)
  bool from_poses = false;              // false: laid out on a line along x
  double spacing_m = 0;                 // median distance between consecutive places, drawn
  double extent_m = 0;   // larger side of the route's bounding box (0 for one place), true
  double scale_m = 0;    // what markers are sized for: min(extent, view size)
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // of the bounding box
  bool fits_view = true;                             // extent_m <= view_size_m
  // Drawn size / true size: 1 when the route fits the view, else view_size_m / extent_m
  // (x and y shrunk about the centre; z kept).
  double draw_scale = 1;
};

RouteDrawing MakeRouteDrawing(const PlaceLayout& places, const BeliefViewOptions& options);

// Marker sizes in metres, each a fixed fraction of route.scale_m (the bar width also
// follows the spacing of the places, within bounds).
struct MarkerSizes {
  double bar_height_m, bar_width_m, route_width_m, pin_diameter_m, true_place_m;
  double label_height_m, legend_height_m;  // text heights
};
MarkerSizes SizesFor(const RouteDrawing& route, int places_per_bar);

// Where the view frame goes, whatever the match: the centre of the route as drawn (all of it
// is in view).
Eigen::Vector3d ViewFocus(const RouteDrawing& route);

// The step between numbered places: 1, 2 or 5 times a power of ten, the smallest that
// numbers at most kPlaceNumbers + 1 places of `num_places` (0, step, 2 step, ...).
int PlaceNumberStep(int num_places);

// The lines of text that describe a belief, for the marker label and the match image:
// "place 812 of 1500", the confidence ("p 0.97, log-odds 3.42" for Bayesian and +seq
// methods, "distance 0.123" for distance methods), "ACCEPTED" or "not accepted (h ...)"
// is left to the caller, and the selected sets (with their weights when the method
// weighted them).
std::vector<std::string> BeliefLabelLines(const Belief& belief, bool probabilistic);

// The true places (namespace true_places) for a belief with `header`; nullopt when none of
// them is a place of the route.
std::optional<visualization_msgs::Marker> TruePlacesMarker(const RouteDrawing& route,
                                                           const std::vector<int>& true_places,
                                                           const std_msgs::Header& header,
                                                           const BeliefViewOptions& options);

// Everything of the view for one belief: a DELETEALL, then the namespaces above, stamped
// with the belief's stamp in options.map_frame. `true_places` may be empty. `probabilistic`:
// the belief's confidence is a log-odds (Bayesian or +seq method).
visualization_msgs::MarkerArray MakeBeliefMarkers(const RouteDrawing& route, const Belief& belief,
                                                  const std::vector<int>& true_places,
                                                  bool probabilistic,
                                                  const BeliefViewOptions& options);

}  // namespace bsf_vpr
