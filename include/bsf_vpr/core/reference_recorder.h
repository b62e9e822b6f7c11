// Records a new reference set from descriptors that stream in (a robot adding today's
// traversal to its map). How the descriptors become places (RecordingPlaces):
//   kSequential  the k-th descriptor is place k (frame-aligned routes, as Nordland);
//   kPose        each descriptor comes with the robot's pose; at the end the traversal is
//                associated with the map's places (place_index.h: the nearest descriptor
//                within a radius and heading of each place), or, on a map without poses,
//                places are made every place_spacing_m along it;
//   kLocalized   each descriptor comes with the place the running localisation accepted
//                for it; a place keeps its most confident descriptor (a robot without GPS
//                adds tonight's traversal to the places it already knows).
//
// Not thread-safe: callers serialise access.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

enum class RecordingPlaces { kSequential, kPose, kLocalized };
// Their names (the start_recording service's places).
const EnumNames<RecordingPlaces>& RecordingPlacesNames();
RecordingPlaces ParseRecordingPlaces(const std::string& name);  // throws naming the choices
std::string ToString(RecordingPlaces places);

// The place the localisation accepted for a descriptor, and how sure it was (log-odds).
struct LocalizedPlace {
  int place = -1;
  double confidence = 0;
};

class ReferenceRecorder {
 public:
  // Starts a recording. `dimension` 0 accepts the dimension of the first descriptor.
  // Throws std::invalid_argument if a recording is running or the name is empty.
  void Start(const std::string& name, const std::string& condition, int dimension,
             RecordingPlaces places = RecordingPlaces::kSequential);
  RecordingPlaces places() const { return places_; }
  bool recording() const { return recording_; }
  const std::string& name() const { return name_; }
  int count() const { return static_cast<int>(rows_.size()); }

  // Adds one descriptor, with the robot's pose if known (required by kPose) and the place
  // the localisation accepted for it (required by kLocalized). Throws
  // std::invalid_argument if no recording runs, for a wrong dimension, a descriptor that
  // QueryDescriptorProblem refuses (not finite, all zeros), a pose that PoseProblem refuses
  // (place_layout.h), or without what the mode needs (nothing is added).
  void Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
           const std::optional<PlacePose>& pose = std::nullopt,
           const std::optional<LocalizedPlace>& localized = std::nullopt);

  // The map the recording is for: the pose of each of its places (nullopt where it has
  // none; as many entries as the map has places), and how to associate with them.
  struct Map {
    std::vector<std::optional<PlacePose>> place_poses;
    PlaceIndexOptions options;
  };

  // Ends the recording and returns the set (see Build).
  ReferenceSet Finish(const std::string& descriptor_type = "", const Map& map = {});
  // The set recorded so far, the recording left running (so that a save that fails loses
  // nothing: Discard once it succeeded). kSequential keeps poses only if every descriptor
  // had one; kPose keeps each chosen descriptor's pose; kLocalized the map's pose of each
  // place (if the map has one for all of them). Throws std::invalid_argument if nothing was
  // recorded, or if kPose finds no place of the map along the traversal (the recording
  // stays open).
  // `source_rows`, if given, receives for each row of the set the index (in the order of
  // Add) of the descriptor it holds, e.g. to keep that descriptor's image beside it.
  ReferenceSet Build(const std::string& descriptor_type = "", const Map& map = {},
                     std::vector<int>* source_rows = nullptr) const;
  // Ends the recording and drops what was recorded.
  void Discard();

 private:
  // Each fills `source` with the recorded row of each of the set's rows.
  ReferenceSet BuildByPose(RowMatrixXf rows, const Map& map, std::vector<int>* source) const;
  ReferenceSet BuildLocalized(RowMatrixXf rows, const Map& map, std::vector<int>* source) const;

  bool recording_ = false;
  RecordingPlaces places_ = RecordingPlaces::kSequential;
  std::string name_, condition_;
  int dimension_ = 0;
  std::vector<Eigen::VectorXf> rows_;
  std::vector<std::optional<PlacePose>> poses_;
  std::vector<LocalizedPlace> localized_;  // kLocalized: one per row
};

}  // namespace bsf_vpr
