// The place layout of a map: its sets, the place each of their rows shows and the places'
// poses, without descriptors. It is what deciding a belief and showing it need of a map, so
// a process that holds no descriptors (the combiner of a sharded map, docs/sharding.md)
// holds a layout and nothing else; a ReferenceSets keeps one beside its descriptors.
//
// Places are numbered 0..N-1 in one place index shared by every set; N grows to cover the
// largest place id of any set. Not thread-safe: callers serialise access.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

// One set as a layout sees it: its descriptors stay where they are held.
struct SetLayout {
  std::string name;
  std::string condition;
  std::string descriptor_type;
  std::vector<int> place_ids;    // N_u place indices, distinct, in [0, N): row k shows place_ids[k]
  std::vector<PlacePose> poses;  // empty, or N_u (poses[k] is the pose of row k)
  // Row k's image is images + "/" + image_files[k] (image_files empty: no images).
  std::string images;
  std::vector<std::string> image_files;
  int dimension = 0;  // D of the set's descriptors

  int size() const { return static_cast<int>(place_ids.size()); }
};

// Largest |x|, |y| or |z| of a pose, in metres. Every frame a robot localises in on Earth
// stays below it with room to spare (UTM northings reach 1e7 m south of the equator, ECEF
// coordinates 6.4e6 m), so a larger coordinate is a broken pose (a unit or sign error, a
// garbage value), not a place.
constexpr double kMaxPoseCoordinateM = 1e8;

// Why `pose` cannot be a place's pose or the robot's ("" if it can): a coordinate or yaw
// that is NaN or infinite, or a coordinate beyond kMaxPoseCoordinateM. Names the field and
// its value ("x = nan").
std::string PoseProblem(const PlacePose& pose);

// Throws std::invalid_argument naming `who` and the problem when the rows' place ids, poses
// or image files cannot describe N_u = place_ids.size() rows: none, a negative, duplicated
// or too large (kMaxPlaces) place id, poses or image files neither empty nor one per row, a
// pose that PoseProblem refuses (naming its row and place), an images folder without files
// or the other way round, an image file that ImageFileProblem refuses.
void CheckPlaceRows(const std::string& who, const std::vector<int>& place_ids,
                    const std::vector<PlacePose>& poses, const std::string& images,
                    const std::vector<std::string>& image_files);

// How far apart two sets may put one place before a set is refused (place_pose_tolerance_m):
// the default of every map, written once.
constexpr double kDefaultPlacePoseToleranceM = 25;

class PlaceLayout {
 public:
  // Two sets that put one place more than this far apart (metres, planar) do not share a
  // place index: Add refuses the second. Default kDefaultPlacePoseToleranceM; +infinity turns
  // the check off.
  void SetPlacePoseTolerance(double metres) { place_pose_tolerance_m_ = metres; }
  double place_pose_tolerance_m() const { return place_pose_tolerance_m_; }
  // Throws std::invalid_argument naming the place and the distance when set `name` puts a
  // place (row k at place_ids[k], poses[k]) farther than place_pose_tolerance_m() from the
  // pose the layout has for it.
  void CheckPlacePoses(const std::string& name, const std::vector<int>& place_ids,
                       const std::vector<PlacePose>& poses) const;

  // Adds a set after checking it (a name; a dimension in [1, kMaxDimension]; CheckPlaceRows;
  // its name free; its dimension the layout's; no place id far beyond the set and the
  // layout, kMaxPlaceIdGrowth; poses that agree, CheckPlacePoses). Throws
  // std::invalid_argument, the layout unchanged.
  void Add(SetLayout set);
  // Removes the named set; returns false if there is none.
  bool Remove(const std::string& name);

  int num_sets() const { return static_cast<int>(sets_.size()); }
  int num_places() const { return num_places_; }
  int dimension() const { return dimension_; }  // 0 while empty
  const std::vector<SetLayout>& sets() const { return sets_; }
  const SetLayout& set(int u) const { return sets_.at(static_cast<size_t>(u)); }
  int IndexOf(const std::string& name) const;  // -1 if none
  std::vector<std::string> SetNames() const;
  // The pose of a place from the first set that has one for it (O(1)).
  std::optional<PlacePose> PoseOf(int place) const;
  // PoseOf of every place: num_places() entries.
  const std::vector<std::optional<PlacePose>>& place_poses() const { return place_poses_; }
  // Median distance (metres) between consecutive places that both have poses; nullopt if
  // no two consecutive places do. O(1): kept up to date by Add and Remove.
  std::optional<double> MedianPlaceSpacing() const { return median_spacing_; }
  // The same of any per-place poses (nullopt where a place has none).
  static std::optional<double> MedianSpacing(const std::vector<std::optional<PlacePose>>& poses);

 private:
  std::vector<SetLayout> sets_;
  std::vector<std::optional<PlacePose>> place_poses_;  // num_places_ entries
  std::optional<double> median_spacing_;
  int num_places_ = 0;
  int dimension_ = 0;
  double place_pose_tolerance_m_ = kDefaultPlacePoseToleranceM;
};

}  // namespace bsf_vpr
