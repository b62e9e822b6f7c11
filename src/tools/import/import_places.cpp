#include "src/tools/import/import_places.h"

#include <algorithm>
#include <cmath>

namespace bsf_vpr {
namespace tools {

SharedPlaceIndex::SharedPlaceIndex(const PlaceIndexOptions& options) : options_(options) {
  options_.Validate();
}

PlaceAssignment SharedPlaceIndex::Add(const std::vector<PlacePose>& frame_poses) {
  PlaceAssignment a = place_poses_.empty()
                          ? MakePlacesAlongRoute(frame_poses, options_)
                          : AssociateWithPlaces(frame_poses, place_poses_, options_);
  for (size_t k = 0; k < a.place_ids.size(); ++k) {
    const size_t id = static_cast<size_t>(a.place_ids[k]);
    if (id >= place_poses_.size()) place_poses_.resize(id + 1);
    if (!place_poses_[id]) place_poses_[id] = a.place_poses[k];
  }
  return a;
}

PlacesWithinRadius::PlacesWithinRadius(const std::vector<std::optional<PlacePose>>& place_poses,
                                       double radius_m)
    : radius_m_(radius_m) {
  for (size_t i = 0; i < place_poses.size(); ++i) {
    if (place_poses[i])
      by_x_.push_back({place_poses[i]->x_m, place_poses[i]->y_m, static_cast<int>(i)});
  }
  std::sort(by_x_.begin(), by_x_.end(), [](const Entry& a, const Entry& b) { return a.x < b.x; });
}

std::vector<int> PlacesWithinRadius::Around(const PlacePose& pose) const {
  const auto first = std::lower_bound(by_x_.begin(), by_x_.end(), pose.x_m - radius_m_,
                                      [](const Entry& e, double x) { return e.x < x; });
  std::vector<int> out;
  for (auto it = first; it != by_x_.end() && it->x <= pose.x_m + radius_m_; ++it) {
    if (std::hypot(it->x - pose.x_m, it->y - pose.y_m) <= radius_m_) out.push_back(it->place);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace tools
}  // namespace bsf_vpr
