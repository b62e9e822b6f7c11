#include "bsf_vpr/core/place_layout.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

std::string PoseProblem(const PlacePose& pose) {
  struct Field {
    const char* name;
    double value;
    bool coordinate;  // bounded by kMaxPoseCoordinateM; the yaw only needs to be finite
  };
  const Field fields[] = {{"x", pose.x_m, true},
                          {"y", pose.y_m, true},
                          {"z", pose.z_m, true},
                          {"yaw", pose.yaw_rad, false}};
  for (const Field& f : fields) {
    const bool finite = std::isfinite(f.value);
    if (finite && !(f.coordinate && std::abs(f.value) > kMaxPoseCoordinateM)) continue;
    std::ostringstream m;
    m << "has " << f.name << " = " << f.value;
    if (!finite) {
      m << " (a pose must be finite)";
    } else {
      m << " m, beyond the " << kMaxPoseCoordinateM << " m any frame on Earth stays within";
    }
    return m.str();
  }
  return "";
}

void CheckPlaceRows(const std::string& who, const std::vector<int>& place_ids,
                    const std::vector<PlacePose>& poses, const std::string& images,
                    const std::vector<std::string>& image_files) {
  if (place_ids.empty()) throw std::invalid_argument(who + " has no rows");
  std::vector<int> sorted = place_ids;
  std::sort(sorted.begin(), sorted.end());
  if (sorted.front() < 0) {
    throw std::invalid_argument(who + " has a negative place id " + std::to_string(sorted.front()));
  }
  const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
  if (dup != sorted.end()) {
    throw std::invalid_argument(who + " has two descriptors for place " + std::to_string(*dup) +
                                " (at most one per place)");
  }
  if (!poses.empty() && poses.size() != place_ids.size()) {
    throw std::invalid_argument(who + " has " + std::to_string(poses.size()) + " poses for " +
                                std::to_string(place_ids.size()) + " places");
  }
  for (size_t k = 0; k < poses.size(); ++k) {
    const std::string problem = PoseProblem(poses[k]);
    if (!problem.empty()) {
      throw std::invalid_argument(who + ": the pose of row " + std::to_string(k) + " (place " +
                                  std::to_string(place_ids[k]) + ") " + problem);
    }
  }
  if (!image_files.empty() && image_files.size() != place_ids.size()) {
    throw std::invalid_argument(who + " has " + std::to_string(image_files.size()) +
                                " image files for " + std::to_string(place_ids.size()) +
                                " descriptors (one per row)");
  }
  if (images.empty() != image_files.empty()) {
    throw std::invalid_argument(who + (images.empty() ? " lists image files but no images folder"
                                                      : " has an images folder but no image "
                                                        "files (one per row)"));
  }
  for (size_t k = 0; k < image_files.size(); ++k) {
    const std::string problem = ImageFileProblem(image_files[k]);
    if (!problem.empty()) {
      throw std::invalid_argument(who + ": image file of row " + std::to_string(k) + " " + problem);
    }
  }
  if (sorted.back() >= kMaxPlaces) {
    throw std::invalid_argument(who + " has place id " + std::to_string(sorted.back()) +
                                ", beyond the largest place id accepted (" +
                                std::to_string(kMaxPlaces - 1) + ")");
  }
}

namespace {

// Gives each place of `set` without a pose in *poses the set's pose for it (the first set
// with a pose for a place wins).
void IndexPoses(const SetLayout& set, std::vector<std::optional<PlacePose>>* poses) {
  for (size_t k = 0; k < set.poses.size(); ++k) {
    std::optional<PlacePose>& slot = (*poses)[static_cast<size_t>(set.place_ids[k])];
    if (!slot) slot = set.poses[k];
  }
}

}  // namespace

void PlaceLayout::CheckPlacePoses(const std::string& name, const std::vector<int>& place_ids,
                                  const std::vector<PlacePose>& poses) const {
  std::vector<std::optional<PlacePose>> theirs(place_poses_.size());
  for (size_t k = 0; k < poses.size(); ++k) {
    const size_t place = static_cast<size_t>(place_ids[k]);
    if (place < theirs.size()) theirs[place] = poses[k];
  }
  const std::optional<PoseConflict> c =
      FindPoseConflict(place_poses_, theirs, place_pose_tolerance_m_);
  if (c) {
    std::ostringstream m;
    m.precision(1);
    m << std::fixed << "reference set '" << name << "' puts place " << c->place << " "
      << c->distance_m << " m from where the loaded sets have it (tolerance "
      << place_pose_tolerance_m_ << " m): its place ids do not belong to this map's place index";
    throw std::invalid_argument(m.str());
  }
}

void PlaceLayout::Add(SetLayout set) {
  if (set.name.empty()) throw std::invalid_argument("a reference set needs a non-empty name");
  if (set.dimension < 1 || set.dimension > kMaxDimension) {
    throw std::invalid_argument("reference set '" + set.name + "' has dimension " +
                                std::to_string(set.dimension) + " (1 to " +
                                std::to_string(kMaxDimension) + ")");
  }
  CheckPlaceRows("reference set '" + set.name + "'", set.place_ids, set.poses, set.images,
                 set.image_files);
  if (IndexOf(set.name) >= 0) {
    throw std::invalid_argument("a reference set named '" + set.name + "' is already loaded");
  }
  if (dimension_ != 0 && set.dimension != dimension_) {
    throw std::invalid_argument("reference set '" + set.name + "' has descriptors of dimension " +
                                std::to_string(set.dimension) + ", the map holds dimension " +
                                std::to_string(dimension_));
  }
  // A place id far beyond both the map and the set is a mistake, not a map: refuse it before
  // the place index grows to hold it.
  const int max_id = *std::max_element(set.place_ids.begin(), set.place_ids.end());
  const int64_t limit = std::max<int64_t>(num_places_, set.size()) * kMaxPlaceIdGrowth + 1000;
  if (max_id >= limit) {
    throw std::invalid_argument(
        "reference set '" + set.name + "' has place id " + std::to_string(max_id) +
        ", far beyond its " + std::to_string(set.size()) + " descriptors and the map's " +
        std::to_string(num_places_) + " places (at most " + std::to_string(limit - 1) + ")");
  }
  CheckPlacePoses(set.name, set.place_ids, set.poses);
  // Built aside; the layout changes only by moves below.
  const int num_places = std::max(num_places_, max_id + 1);
  std::vector<std::optional<PlacePose>> poses = place_poses_;
  poses.resize(static_cast<size_t>(num_places));
  IndexPoses(set, &poses);
  const std::optional<double> spacing = MedianSpacing(poses);
  const int dimension = set.dimension;
  sets_.reserve(sets_.size() + 1);
  sets_.push_back(std::move(set));  // cannot throw after the reserve
  dimension_ = dimension;
  num_places_ = num_places;
  place_poses_ = std::move(poses);
  median_spacing_ = spacing;
}

bool PlaceLayout::Remove(const std::string& name) {
  const int u = IndexOf(name);
  if (u < 0) return false;
  // The new place index is built aside; the layout changes only once it is complete.
  int num_places = 0;
  for (size_t k = 0; k < sets_.size(); ++k) {
    if (static_cast<int>(k) == u) continue;
    const std::vector<int>& ids = sets_[k].place_ids;
    num_places = std::max(num_places, 1 + *std::max_element(ids.begin(), ids.end()));
  }
  std::vector<std::optional<PlacePose>> poses(static_cast<size_t>(num_places));
  for (size_t k = 0; k < sets_.size(); ++k) {
    if (static_cast<int>(k) != u) IndexPoses(sets_[k], &poses);
  }
  const std::optional<double> spacing = MedianSpacing(poses);
  sets_.erase(sets_.begin() + u);
  num_places_ = num_places;
  place_poses_ = std::move(poses);
  median_spacing_ = spacing;
  if (sets_.empty()) dimension_ = 0;
  return true;
}

int PlaceLayout::IndexOf(const std::string& name) const {
  for (size_t u = 0; u < sets_.size(); ++u) {
    if (sets_[u].name == name) return static_cast<int>(u);
  }
  return -1;
}

std::vector<std::string> PlaceLayout::SetNames() const {
  std::vector<std::string> names;
  for (const SetLayout& s : sets_) names.push_back(s.name);
  return names;
}

std::optional<PlacePose> PlaceLayout::PoseOf(int place) const {
  if (place < 0 || place >= num_places_) return std::nullopt;
  return place_poses_[static_cast<size_t>(place)];
}

std::optional<double> PlaceLayout::MedianSpacing(
    const std::vector<std::optional<PlacePose>>& poses) {
  std::vector<double> gaps;
  for (size_t i = 1; i < poses.size(); ++i) {
    const std::optional<PlacePose>& prev = poses[i - 1];
    const std::optional<PlacePose>& cur = poses[i];
    if (prev && cur) {
      gaps.push_back(std::sqrt((cur->x_m - prev->x_m) * (cur->x_m - prev->x_m) +
                               (cur->y_m - prev->y_m) * (cur->y_m - prev->y_m) +
                               (cur->z_m - prev->z_m) * (cur->z_m - prev->z_m)));
    }
  }
  if (gaps.empty()) return std::nullopt;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  return gaps[gaps.size() / 2];
}

}  // namespace bsf_vpr
