// The one place index that the reference sets of an import share, and the ground truth of
// query frames by position.
#pragma once

#include <optional>
#include <vector>

#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {
namespace tools {

// Places by position for several traversals: the first traversal added makes the places
// (MakePlacesAlongRoute, ids 0..), every later one is associated with them
// (AssociateWithPlaces: the places it passes get its nearest frame, the others stay
// uncovered) and, with options.add_new_places, adds its route beyond them as new places
// (ids after the existing ones). Poses are in the map frame (metres, radians).
class SharedPlaceIndex {
 public:
  explicit SharedPlaceIndex(const PlaceIndexOptions& options);  // validates the options

  // Assigns the places of one traversal (`frame_poses`, in time order) and adds its new
  // places to the index. Throws std::invalid_argument for no frames or a non-finite pose.
  PlaceAssignment Add(const std::vector<PlacePose>& frame_poses);

  int num_places() const { return static_cast<int>(place_poses_.size()); }
  // The pose of every place: that of the frame that made it (a later traversal's frames
  // associated with it do not move it).
  const std::vector<std::optional<PlacePose>>& place_poses() const { return place_poses_; }

 private:
  PlaceIndexOptions options_;
  std::vector<std::optional<PlacePose>> place_poses_;
};

// The places whose planar distance (x, y) to a pose is at most a radius: the correct
// places of a query at that pose. O(log N + places in the x band) per lookup.
class PlacesWithinRadius {
 public:
  // `place_poses[i]` is place i's pose (nullopt: never found). Copies what it needs.
  PlacesWithinRadius(const std::vector<std::optional<PlacePose>>& place_poses, double radius_m);
  // The places within the radius of `pose`, ascending.
  std::vector<int> Around(const PlacePose& pose) const;

 private:
  struct Entry {
    double x, y;
    int place;
  };
  std::vector<Entry> by_x_;  // sorted by x
  double radius_m_;
};

}  // namespace tools
}  // namespace bsf_vpr
