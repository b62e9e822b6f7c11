// Reference sets (one traversal's descriptors) and the reference map that holds M of them.
//
// Places are numbered 0..N-1 in a place index shared by all sets of a map. A set covers some
// of those places, with at most one descriptor per place (paper, Sec. III-A).
//
// A ReferenceSet is the plain value that files, tools and the recorder produce and consume
// (float32 descriptors and their metadata). ReferenceSets::Add turns it into the immutable
// StoredReferenceSet the map keeps, encoded at the map's storage precision.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/descriptor_store.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/stored_reference_set.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

// Bounds on what a map may hold, checked before anything is allocated for it: place ids lie
// in [0, kMaxPlaces), descriptors have at most kMaxDimension elements.
constexpr int kMaxPlaces = 1 << 27;
constexpr int kMaxDimension = 1 << 20;
// A set may add places up to kMaxPlaceIdGrowth x max(its descriptors, the map's places)
// (+1000); a larger id is taken for a mistake (e.g. a typo of 2000000000).
constexpr int64_t kMaxPlaceIdGrowth = 1000;
// Largest squared L2 norm of a descriptor: float32 distances between two such descriptors
// stay finite (4 x this < FLT_MAX).
constexpr double kMaxDescriptorSquaredNorm = 8.0e37;

struct ReferenceSet {
  std::string name;              // unique within a map, e.g. "winter"
  std::string condition;         // optional label, e.g. "snow", "night"
  std::string descriptor_type;   // optional, e.g. "patchnorm_64x32_p8", "netvlad_4096"
  std::string distance;          // optional, the distance the descriptors are meant for
  RowMatrixXf descriptors;       // N_u x D, row k describes place place_ids[k]
  // Or the N_u x D rows already encoded (a memory-mapped .npy: EncodedRows), in which case
  // `descriptors` is empty. ReferenceSets::Add holds them as they are when they are at the
  // map's storage precision, and refuses them otherwise; nothing else reads them.
  std::optional<EncodedRows> encoded;
  std::vector<int> place_ids;    // N_u place indices, distinct, in [0, N)
  std::vector<PlacePose> poses;  // empty, or N_u poses (poses[k] is the pose of row k)
  // The images the rows were described from, for showing a match: row k's image is
  // images + "/" + image_files[k]. `images` is a folder (absolute once loaded from a file);
  // image_files is empty (no images) or holds N_u paths relative to it.
  std::string images;
  std::vector<std::string> image_files;

  int size() const { return static_cast<int>(encoded ? encoded->rows : descriptors.rows()); }
  int dimension() const { return static_cast<int>(encoded ? encoded->cols : descriptors.cols()); }
  // Its metadata as a map's layout holds it (every field but the rows and the distance).
  SetLayout Layout() const;
  // The same, moved out of this set (its names, ids, poses and images left empty).
  SetLayout TakeLayout();

  // Throws std::invalid_argument naming the problem: empty name or set, place ids missing,
  // duplicated, negative or >= kMaxPlaces, poses of the wrong count or one that PoseProblem
  // refuses (place_layout.h: not finite, or beyond kMaxPoseCoordinateM), a descriptor that
  // DescriptorProblem refuses, image_files neither empty nor one per row, images given
  // without image_files or the other way round, an image file that ImageFileProblem refuses.
  void Validate() const;
};

// Why a descriptor cannot be used ("" if it can): a NaN or infinite value, or a norm so
// large (finite values near 3.4e38) that float32 distances would overflow.
std::string DescriptorProblem(const Eigen::Ref<const Eigen::RowVectorXf>& descriptor);

// Why `descriptor` cannot be a query or a recorded place ("" if it can): DescriptorProblem's
// reasons, or a descriptor of all zeros, which carries no information. Such a descriptor is
// what the patch-normalised descriptor and HOG give for a uniform image (a black frame, a
// covered lens, a 1x1 image); it has cosine distance 1 to every reference (no similarity is
// defined) and Euclidean distance |r| to reference r, which favours references of small norm
// whatever the place, so fused it would be matched on the filter's history alone. A constant
// non-zero descriptor passes: an L2-normalised one may be constant (1/sqrt(D) each), and
// patch normalisation never gives one (each patch has zero mean). A reference set's rows
// are not held to it: a set's row k is its place, and a black frame stays a (distant) place.
std::string QueryDescriptorProblem(const Eigen::Ref<const Eigen::RowVectorXf>& descriptor);

// Why `file` cannot name a set's image below its folder ("" if it can): absolute, or with a
// ".." part (it would climb out of the folder). An empty `file` says the row has no image (a
// recording that kept no camera image for it).
std::string ImageFileProblem(const std::string& file);

// Makes a set whose row k is place k (the usual case for frame-aligned traversals).
ReferenceSet MakeReferenceSet(std::string name, RowMatrixXf descriptors,
                              std::string condition = "");

// M reference sets sharing one descriptor dimension and one place index: their stored
// descriptors and their place layout (layout()). M and N are run-time values; N grows to
// cover the largest place id of any set.
class ReferenceSets {
 public:
  // Precision at which sets added from now on are held (default float32). A set held at
  // reduced precision keeps only its encoded rows: its float32 values are released.
  void SetStoragePrecision(StoragePrecision precision) { storage_ = precision; }
  StoragePrecision storage_precision() const { return storage_; }
  // Two sets that put one place more than this far apart (metres, planar) do not share a
  // place index: Add refuses the second. Default 25 m; +infinity turns the check off.
  void SetPlacePoseTolerance(double metres) { layout_.SetPlacePoseTolerance(metres); }
  double place_pose_tolerance_m() const { return layout_.place_pose_tolerance_m(); }
  // Throws std::invalid_argument naming the place and the distance when `set` puts a place
  // farther than place_pose_tolerance_m() from the pose the map has for it.
  void CheckPlacePoses(const ReferenceSet& set) const;

  // Adds a set after validating it, held from now on as a StoredReferenceSet at
  // storage_precision(). Throws std::invalid_argument if it is invalid, if its name is
  // taken, if its dimension differs from the sets already held, if a place id lies far
  // beyond the set and the map (kMaxPlaceIdGrowth), if its poses contradict the map's
  // (CheckPlacePoses), or if float16 cannot hold a value; the
  // map is unchanged whenever it throws (std::bad_alloc included).
  void Add(ReferenceSet set);
  // A set validated and encoded at `precision`, ready to join a map of that precision
  // (Add(StoredReferenceSet)): the part of Add that reads every row and needs no map, so
  // that whoever guards a map with a lock can do it before taking the lock. Throws as Add
  // does for the set itself.
  static StoredReferenceSet Store(ReferenceSet set, StoragePrecision precision);
  // Adds a set Store made: the layout's checks, then the set. Throws std::invalid_argument
  // as Add(ReferenceSet) does for the map's checks, and when the set is held at another
  // precision than storage_precision(); the map is unchanged whenever it throws.
  void Add(StoredReferenceSet set);
  // Removes the named set; returns false if there is none.
  bool Remove(const std::string& name);
  // Throws std::invalid_argument naming the problem when `descriptor` cannot be compared
  // with the sets: none is loaded, it has another dimension, or QueryDescriptorProblem
  // refuses it (not finite, too large, or all zeros).
  void CheckQuery(const Eigen::Ref<const Eigen::VectorXf>& descriptor) const;

  int num_sets() const { return static_cast<int>(sets_.size()); }
  int num_places() const { return layout_.num_places(); }
  int dimension() const { return layout_.dimension(); }  // 0 while empty
  const std::vector<StoredReferenceSet>& sets() const { return sets_; }
  const StoredReferenceSet& set(int u) const { return sets_.at(static_cast<size_t>(u)); }
  // The sets' places and poses, set u of it describing set(u) (what a belief is decided
  // and shown on; see place_layout.h).
  const PlaceLayout& layout() const { return layout_; }
  // A map is seen as its layout wherever only places are needed.
  operator const PlaceLayout&() const { return layout_; }  // NOLINT(google-explicit-constructor)
  // Index of the named set, or -1.
  int IndexOf(const std::string& name) const { return layout_.IndexOf(name); }
  std::vector<std::string> SetNames() const { return layout_.SetNames(); }
  // The pose of a place from the first set that has one for it (O(1): an index kept by
  // Add and Remove).
  std::optional<PlacePose> PoseOf(int place) const { return layout_.PoseOf(place); }
  // PoseOf of every place: num_places() entries.
  const std::vector<std::optional<PlacePose>>& place_poses() const { return layout_.place_poses(); }
  // Median distance (metres) between consecutive places that both have poses; nullopt if
  // no two consecutive places do. O(1): kept up to date by Add and Remove.
  std::optional<double> MedianPlaceSpacing() const { return layout_.MedianPlaceSpacing(); }
  // The same of any per-place poses (PlaceLayout::MedianSpacing).
  static std::optional<double> MedianSpacing(const std::vector<std::optional<PlacePose>>& poses) {
    return PlaceLayout::MedianSpacing(poses);
  }

 private:
  // Appends `stored` and adopts `next` (its layout with the set): no throw.
  void Insert(StoredReferenceSet stored, PlaceLayout next);

  std::vector<StoredReferenceSet> sets_;
  PlaceLayout layout_;  // set u of it is sets_[u]'s
  StoragePrecision storage_ = StoragePrecision::kFloat32;
};

}  // namespace bsf_vpr
