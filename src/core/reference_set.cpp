#include "bsf_vpr/core/reference_set.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace bsf_vpr {

size_t ReferenceSet::MemoryBytes() const {
  return static_cast<size_t>(descriptors.size()) * sizeof(float) + store.MemoryBytes() +
         place_ids.size() * sizeof(int) + poses.size() * sizeof(PlacePose);
}

const void* ReferenceSet::StoredData() const {
  switch (store.precision) {
    case StoragePrecision::kFloat16:
      return store.half.data();
    case StoragePrecision::kInt8:
      return store.int8.data();
    default:
      return descriptors.data();
  }
}

size_t ReferenceSet::StoredBytes() const {
  return static_cast<size_t>(size()) * static_cast<size_t>(dimension()) *
         static_cast<size_t>(BytesPerElement(store.precision));
}

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
  if (!descriptors.allFinite()) {
    for (Eigen::Index r = 0; r < descriptors.rows(); ++r) {
      if (!descriptors.row(r).allFinite()) {
        throw std::invalid_argument(who + ": descriptor row " + std::to_string(r) +
                                    " holds NaN or infinity");
      }
    }
  }
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
  set.store = MakeDescriptorStore(set.descriptors, storage_);  // throws before any change
  if (storage_ != StoragePrecision::kFloat32) set.descriptors.resize(0, set.descriptors.cols());
  const int max_id = *std::max_element(set.place_ids.begin(), set.place_ids.end());
  dimension_ = set.dimension();
  num_places_ = std::max(num_places_, max_id + 1);
  place_poses_.resize(static_cast<size_t>(num_places_));
  IndexPoses(set);
  UpdateMedianSpacing();
  sets_.push_back(std::move(set));
}

void ReferenceMap::IndexPoses(const ReferenceSet& set) {
  for (size_t k = 0; k < set.poses.size(); ++k) {
    std::optional<PlacePose>& slot = place_poses_[static_cast<size_t>(set.place_ids[k])];
    if (!slot) slot = set.poses[k];  // the first set with a pose for the place wins
  }
}

bool ReferenceMap::Remove(const std::string& name) {
  const int u = IndexOf(name);
  if (u < 0) return false;
  sets_.erase(sets_.begin() + u);
  num_places_ = 0;
  for (const ReferenceSet& s : sets_) {
    num_places_ =
        std::max(num_places_, 1 + *std::max_element(s.place_ids.begin(), s.place_ids.end()));
  }
  place_poses_.assign(static_cast<size_t>(num_places_), std::nullopt);
  for (const ReferenceSet& s : sets_) IndexPoses(s);
  UpdateMedianSpacing();
  if (sets_.empty()) dimension_ = 0;
  return true;
}

int ReferenceMap::IndexOf(const std::string& name) const {
  for (size_t u = 0; u < sets_.size(); ++u) {
    if (sets_[u].name == name) return static_cast<int>(u);
  }
  return -1;
}

std::vector<std::string> ReferenceMap::SetNames() const {
  std::vector<std::string> names;
  for (const ReferenceSet& s : sets_) names.push_back(s.name);
  return names;
}

std::optional<PlacePose> ReferenceMap::PoseOf(int place) const {
  if (place < 0 || place >= num_places_) return std::nullopt;
  return place_poses_[static_cast<size_t>(place)];
}

void ReferenceMap::UpdateMedianSpacing() {
  median_spacing_.reset();
  std::vector<double> gaps;
  std::optional<PlacePose> prev = PoseOf(0);
  for (int i = 1; i < num_places_; ++i) {
    const std::optional<PlacePose> cur = PoseOf(i);
    if (prev && cur) {
      gaps.push_back(std::sqrt((cur->x_m - prev->x_m) * (cur->x_m - prev->x_m) +
                               (cur->y_m - prev->y_m) * (cur->y_m - prev->y_m) +
                               (cur->z_m - prev->z_m) * (cur->z_m - prev->z_m)));
    }
    prev = cur;
  }
  if (gaps.empty()) return;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  median_spacing_ = gaps[gaps.size() / 2];
}

}  // namespace bsf_vpr
