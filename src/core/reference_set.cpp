#include "bsf_vpr/core/reference_set.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "bsf_vpr/core/place_index.h"

namespace bsf_vpr {

void ReferenceSet::Validate() const {
  const std::string who = "reference set '" + name + "'";
  if (name.empty()) throw std::invalid_argument("a reference set needs a non-empty name");
  if (descriptors.rows() == 0 || descriptors.cols() == 0) {
    throw std::invalid_argument(who + " is empty (" + std::to_string(descriptors.rows()) + " x " +
                                std::to_string(descriptors.cols()) + " descriptors)");
  }
  if (place_ids.size() != static_cast<size_t>(descriptors.rows())) {
    throw std::invalid_argument(who + " has " + std::to_string(descriptors.rows()) +
                                " descriptors but " + std::to_string(place_ids.size()) +
                                " place ids");
  }
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
  if (descriptors.cols() > kMaxDimension) {
    throw std::invalid_argument(who + " has dimension " + std::to_string(descriptors.cols()) +
                                ", more than " + std::to_string(kMaxDimension));
  }
  for (Eigen::Index r = 0; r < descriptors.rows(); ++r) {
    const std::string problem = DescriptorProblem(descriptors.row(r));
    if (!problem.empty()) {
      throw std::invalid_argument(who + ": descriptor row " + std::to_string(r) + " " + problem);
    }
  }
}

std::string DescriptorProblem(const Eigen::Ref<const Eigen::RowVectorXf>& descriptor) {
  // The distances square and sum float32 values: a finite descriptor whose squared norm
  // overflows float32 would turn them into infinity or NaN.
  // In double no finite float32 value overflows a square or a sum (at most kMaxDimension of
  // them), so the sum is finite exactly when every value is: one branch-free pass with four
  // sums in flight (this runs over every row of every set loaded and every query).
  const float* x = descriptor.data();
  const Eigen::Index n = descriptor.size();
  double sums[4] = {0, 0, 0, 0};
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    for (int k = 0; k < 4; ++k) sums[k] += static_cast<double>(x[i + k]) * x[i + k];
  }
  for (; i < n; ++i) sums[0] += static_cast<double>(x[i]) * x[i];
  const double squared_norm = (sums[0] + sums[1]) + (sums[2] + sums[3]);
  if (!std::isfinite(squared_norm)) return "holds NaN or infinity";
  if (squared_norm > kMaxDescriptorSquaredNorm) {
    return "has a norm too large to compute distances with (squared norm " +
           std::to_string(squared_norm) + " > " + std::to_string(kMaxDescriptorSquaredNorm) + ")";
  }
  return "";
}

std::string ImageFileProblem(const std::string& file) {
  if (file.empty()) return "is empty";
  if (file[0] == '/') return "'" + file + "' is absolute (it must be relative to images)";
  size_t start = 0;
  while (start <= file.size()) {
    const size_t slash = std::min(file.find('/', start), file.size());
    if (file.compare(start, slash - start, "..") == 0) {
      return "'" + file + "' has a '..' part (it must lie below images)";
    }
    start = slash + 1;
  }
  return "";
}

ReferenceSet MakeReferenceSet(std::string name, RowMatrixXf descriptors, std::string condition) {
  ReferenceSet set;
  set.name = std::move(name);
  set.condition = std::move(condition);
  set.place_ids.resize(static_cast<size_t>(descriptors.rows()));
  std::iota(set.place_ids.begin(), set.place_ids.end(), 0);
  set.descriptors = std::move(descriptors);
  return set;
}

void ReferenceMap::Add(ReferenceSet set) {
  set.Validate();
  if (IndexOf(set.name) >= 0) {
    throw std::invalid_argument("a reference set named '" + set.name + "' is already loaded");
  }
  if (dimension_ != 0 && set.dimension() != dimension_) {
    throw std::invalid_argument("reference set '" + set.name + "' has descriptors of dimension " +
                                std::to_string(set.dimension()) + ", the map holds dimension " +
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
  CheckPlacePoses(set);
  // Everything that can throw happens aside (encoding, copies); the map changes only by
  // moves below.
  StoredReferenceSet stored(std::move(set), storage_);
  const int num_places = std::max(num_places_, max_id + 1);
  std::vector<std::optional<PlacePose>> poses = place_poses_;
  poses.resize(static_cast<size_t>(num_places));
  IndexPoses(stored, &poses);
  const std::optional<double> spacing = MedianSpacing(poses);
  sets_.reserve(sets_.size() + 1);
  static_assert(std::is_nothrow_move_constructible_v<StoredReferenceSet>);
  sets_.push_back(std::move(stored));  // cannot throw after the reserve
  dimension_ = sets_.back().dimension();
  num_places_ = num_places;
  place_poses_ = std::move(poses);
  median_spacing_ = spacing;
}

void ReferenceMap::CheckPlacePoses(const ReferenceSet& set) const {
  std::vector<std::optional<PlacePose>> theirs(place_poses_.size());
  for (size_t k = 0; k < set.poses.size(); ++k) {
    const size_t place = static_cast<size_t>(set.place_ids[k]);
    if (place < theirs.size()) theirs[place] = set.poses[k];
  }
  const std::optional<PoseConflict> c =
      FindPoseConflict(place_poses_, theirs, place_pose_tolerance_m_);
  if (c) {
    std::ostringstream m;
    m.precision(1);
    m << std::fixed << "reference set '" << set.name << "' puts place " << c->place << " "
      << c->distance_m << " m from where the loaded sets have it (tolerance "
      << place_pose_tolerance_m_ << " m): its place ids do not belong to this map's place index";
    throw std::invalid_argument(m.str());
  }
}

void ReferenceMap::IndexPoses(const StoredReferenceSet& set,
                              std::vector<std::optional<PlacePose>>* poses) {
  for (size_t k = 0; k < set.poses().size(); ++k) {
    std::optional<PlacePose>& slot = (*poses)[static_cast<size_t>(set.place_ids()[k])];
    if (!slot) slot = set.poses()[k];  // the first set with a pose for the place wins
  }
}

bool ReferenceMap::Remove(const std::string& name) {
  const int u = IndexOf(name);
  if (u < 0) return false;
  // The new place index is built aside; the map changes only once it is complete.
  int num_places = 0;
  for (size_t k = 0; k < sets_.size(); ++k) {
    if (static_cast<int>(k) == u) continue;
    const std::vector<int>& ids = sets_[k].place_ids();
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

int ReferenceMap::IndexOf(const std::string& name) const {
  for (size_t u = 0; u < sets_.size(); ++u) {
    if (sets_[u].name() == name) return static_cast<int>(u);
  }
  return -1;
}

std::vector<std::string> ReferenceMap::SetNames() const {
  std::vector<std::string> names;
  for (const StoredReferenceSet& s : sets_) names.push_back(s.name());
  return names;
}

std::optional<PlacePose> ReferenceMap::PoseOf(int place) const {
  if (place < 0 || place >= num_places_) return std::nullopt;
  return place_poses_[static_cast<size_t>(place)];
}

std::optional<double> ReferenceMap::MedianSpacing(
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
