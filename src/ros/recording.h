// The fusion node's recording of a new reference set from the descriptors that reach it
// (what start_recording and stop_recording do), without ROS messages so that it can be
// tested without a master. A recording named NAME is saved below the data directory as
// NAME.yaml with its descriptors beside it (reference_set_io.h), then handed back for the
// node to load.
//
// Nothing is lost: a save that fails keeps the recording, so the caller can free space or
// fix the folder and save again, or discard it.
//
// Not thread-safe: the fusion node holds its lock.
#pragma once

#include <diagnostic_updater/DiagnosticStatusWrapper.h>

#include <Eigen/Core>
#include <optional>
#include <string>

#include "bsf_vpr/core/data_directory.h"
#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/reference_recorder.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

class Recording {
 public:
  // `data_dir` is not owned and must outlive this; null (no data directory configured)
  // refuses every Start.
  explicit Recording(const DataDirectory* data_dir) : data_dir_(data_dir) {}

  // Starts recording `name` (saved as `name`.yaml below the data directory), with the
  // dimension of the sets in `loaded` (any dimension while it holds none). Throws
  // std::invalid_argument naming the problem, and changes nothing, if there is no data
  // directory, the name is not a plain relative path (empty, '.' or '..' parts, control
  // characters, invalid UTF-8), a set of that name is loaded, its YAML exists and
  // `overwrite` is false, or a recording runs already.
  // `places` says how descriptors become places (reference_recorder.h); localized needs a
  // loaded set to localise against.
  void Start(const std::string& name, const std::string& condition, bool overwrite,
             const ReferenceMap& loaded, RecordingPlaces places = RecordingPlaces::kSequential);
  RecordingPlaces places() const { return recorder_.places(); }

  // Adds one descriptor as the next place. `descriptor_type` "" says nothing; otherwise it
  // is the recorded set's type (the last one given wins). Throws std::invalid_argument if no
  // recording runs or the descriptor is refused (another dimension, not finite); nothing is
  // added then, and the type is not taken.
  // `pose` (the robot's, in the map frame) is required when recording by pose, `localized`
  // (the accepted match) when recording by localisation.
  void Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor, const std::string& descriptor_type,
           const std::optional<PlacePose>& pose = std::nullopt,
           const std::optional<LocalizedPlace>& localized = std::nullopt);

  struct Saved {
    ReferenceSet set;  // as written, for the caller to load
    std::string path;  // absolute path of the YAML
  };
  // Saves the recording, meant for `distance`, and ends it. Replaces an existing YAML only
  // if Start was asked to overwrite. Throws std::invalid_argument if no recording runs or it
  // holds no descriptor, and std::runtime_error if writing fails; the recording is kept in
  // either case.
  // With `loaded`, places by pose are associated with its places (`options`), and a set
  // whose poses contradict them (ReferenceMap::CheckPlacePoses) is refused before saving.
  Saved Save(DistanceMetric distance, const ReferenceMap* loaded = nullptr,
             const PlaceIndexOptions& options = {});

  // Ends the recording and drops what it holds. Throws std::invalid_argument if no
  // recording runs.
  void Discard();

  // Throws std::invalid_argument if a set named `set_name` is being recorded: loading it
  // now would leave two sets of that name once the recording is saved.
  void CheckNotRecording(const std::string& set_name) const;

  bool recording() const { return recorder_.recording(); }
  const std::string& name() const { return recorder_.name(); }
  int count() const { return recorder_.count(); }  // descriptors recorded so far

  // Adds a line on the running recording (name and count) to `status`; nothing otherwise.
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const;

 private:
  const DataDirectory* data_dir_;
  ReferenceRecorder recorder_;
  bool overwrite_ = false;  // the recording may replace a set on disk
  std::string descriptor_type_;
};

}  // namespace bsf_vpr
