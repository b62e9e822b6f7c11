// Places by position. A robot never drives a route twice at the same speed: it stops, slows
// down, takes detours. So a place is not a frame number but a position along the route:
// the paper's Oxford RobotCar protocol subsamples each traversal to one place per metre.
//
// Two operations on a traversal (frames in time order, each with a pose in the map frame):
//   MakePlacesAlongRoute: places at a fixed spacing along the driven path (arc length, so a
//     stop adds no place), each kept with the frame nearest to it;
//   AssociateWithPlaces: the places of an existing map that the traversal passes, each with
//     its nearest frame within a radius and a heading tolerance (a place seen in the
//     opposite direction is another view); places it does not pass stay uncovered, and the
//     route beyond the map can add new places.
// Also: poses interpolated at image timestamps, latitude/longitude to local metres, and
// the check that two sets agree on where their common places are.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

struct PlaceIndexOptions {
  double place_spacing_m = 1.0;       // distance between places along the route (paper: 1)
  double association_radius_m = 5.0;  // a frame farther than this from a place is not it
  // A frame whose heading differs from the place's by more than this is not a view of it.
  double max_yaw_difference_deg = 45;
  bool add_new_places = false;  // route beyond the map becomes new places

  // Throws std::invalid_argument naming the bad field (the bounds of PlaceIndexOptionsTable).
  void Validate() const;
};

// The options of PlaceIndexOptions (options.h), for the tools and the fusion node.
const OptionTable<PlaceIndexOptions>& PlaceIndexOptionsTable();

// Which frame describes which place.
struct PlaceAssignment {
  std::vector<int> place_ids;          // one per chosen frame, ascending
  std::vector<int> frames;             // frames[k] is the frame that describes place_ids[k]
  std::vector<PlacePose> place_poses;  // the pose of frames[k], where place_ids[k] was seen
  int new_places = 0;                  // how many of place_ids were added beyond the map
};

// Places every options.place_spacing_m of arc length along the path of `frame_poses`
// (place 0 at the first frame; a stop adds none; a reversal goes on counting distance).
// Each place is the frame nearest the point at that arc length. Place ids start at
// `first_place_id`. Throws std::invalid_argument for no frames or a non-finite pose.
PlaceAssignment MakePlacesAlongRoute(const std::vector<PlacePose>& frame_poses,
                                     const PlaceIndexOptions& options, int first_place_id = 0);

// The places of a map (`place_poses[i]` is place i's pose, nullopt for a place without one)
// that the traversal passes: each place gets the frame nearest to it within
// association_radius_m whose yaw is within max_yaw_difference_deg of the place's; a place
// with none is uncovered. With add_new_places, the stretches of frames that are near no
// place (by position and heading) become new places along their own route, numbered from
// place_poses.size(). Uses a grid over the places: O(frames + places) for a route.
PlaceAssignment AssociateWithPlaces(const std::vector<PlacePose>& frame_poses,
                                    const std::vector<std::optional<PlacePose>>& place_poses,
                                    const PlaceIndexOptions& options);

// A pose track: stamps in seconds, ascending, one pose each.
struct PoseTrack {
  std::vector<double> stamps_s;
  std::vector<PlacePose> poses;
};

// The pose at `stamp_s`, linearly interpolated (yaw the short way round). nullopt when the
// stamp lies outside the track, or between two samples farther apart than max_gap_s.
std::optional<PlacePose> InterpolatePose(const PoseTrack& track, double stamp_s,
                                         double max_gap_s = 1.0);

// East/north metres of (latitude, longitude) in degrees from an origin, on the local
// tangent plane (equirectangular; under 0.1% error within tens of km): x east, y north.
PlacePose LocalMetresFromLatLon(double latitude_deg, double longitude_deg,
                                double origin_latitude_deg, double origin_longitude_deg);

// Sets each pose's yaw to the heading of the path there (from the neighbouring poses at
// least `min_step_m` away; kept from the previous pose while stopped). For tracks without a
// heading, such as GPS positions.
void HeadingsFromPath(std::vector<PlacePose>* poses, double min_step_m = 0.5);

// Where two sets disagree about a place: its id and the distance between their poses.
struct PoseConflict {
  int place = -1;
  double distance_m = 0;
};
// The place whose two poses lie farthest apart, if more than tolerance_m. `a` and `b` are
// the per-place poses of two sets (nullopt where a set has none).
std::optional<PoseConflict> FindPoseConflict(const std::vector<std::optional<PlacePose>>& a,
                                             const std::vector<std::optional<PlacePose>>& b,
                                             double tolerance_m);

// Planar distance (x, y) and the absolute yaw difference wrapped to [0, pi].
double PlanarDistance(const PlacePose& a, const PlacePose& b);
double YawDifference(double a_rad, double b_rad);

}  // namespace bsf_vpr
