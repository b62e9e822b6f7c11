// The fusion node's recording of a new reference set from the descriptors that reach it
// (what start_recording and stop_recording do), without ROS messages so that it can be
// tested without a master. A recording named NAME is saved below the data directory as
// NAME.yaml with its descriptors beside it (reference_set_io.h), then handed back for the
// node to load.
//
// Nothing is lost and nothing is swallowed: a save that fails keeps what was recorded,
// closed to new descriptors (the drive it recorded has ended), so the caller can free space
// or fix the folder and save again, or discard it; until then Start refuses with a message
// saying so. A stop that finds nothing to keep ends the recording and says what arrived.
//
// A recording is bounded (RecordingLimits): it warns once at 90% of either limit and then
// refuses descriptors (RecordingFull), counted as lost; what it holds stays to be saved.
//
// Not thread-safe: the fusion node holds its lock, except for RunSave (see BeginSave).
#pragma once

#include <diagnostic_updater/DiagnosticStatusWrapper.h>

#include <Eigen/Core>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/reference_recorder.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"

namespace bsf_vpr {

// The most a recording holds: descriptors, and bytes (the descriptors' floats and the
// images kept with them). About 0.9 GB an hour of 2048-d descriptors at 30 Hz.
struct RecordingLimits {
  int64_t max_descriptors = 200000;
  int64_t max_bytes = int64_t{2000} * 1000000;
};

// A descriptor refused because the recording holds as much as its limits allow.
class RecordingFull : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class Recording {
 public:
  // `data_dir` is not owned and must outlive this; null (no data directory configured)
  // refuses every Start.
  explicit Recording(const DataDirectory* data_dir, RecordingLimits limits = {})
      : data_dir_(data_dir), limits_(limits) {}

  // Files below the data directory (relative paths) that a save never removes when it
  // replaces a set (SaveOptions::keep): the configured sets' files.
  void set_keep(std::set<std::string> keep) { keep_ = std::move(keep); }

  // Starts recording `name` (saved as `name`.yaml below the data directory), with the
  // dimension of the sets in `loaded` (any dimension while it holds none). Throws
  // std::invalid_argument naming the problem, and changes nothing, if there is no data
  // directory, the name is refused by SetNameProblem (reference_set_io.h) or is not a plain
  // relative path (empty, '.' or '..' parts), a set of that name is loaded, its YAML exists and
  // `overwrite` is false, or a recording runs already or is pending after a failed save (the
  // message says how to save or discard it).
  // `places` says how descriptors become places (reference_recorder.h); localized needs a
  // loaded set to localise against. With `save_images`, each descriptor's camera image
  // (AddImage) is saved beside the set (a folder of the save's own, NAME_images.<8
  // characters>, SaveOptions::images), so that the match image shows it; a place whose
  // image did not come is saved without one (the stop's answer says how many).
  void Start(const std::string& name, const std::string& condition, bool overwrite,
             const PlaceLayout& loaded, RecordingPlaces places = RecordingPlaces::kSequential,
             bool save_images = false);
  RecordingPlaces places() const { return recorder_.places(); }
  bool saves_images() const { return save_images_; }

  // Adds one descriptor as the next place. `descriptor_type` "" says nothing; otherwise it
  // is the recorded set's type (the last one given wins). Throws std::invalid_argument if no
  // recording runs or the descriptor is refused (another dimension, not finite, or a pose
  // that PoseProblem refuses: counted as lost); nothing is added then, and the type is not
  // taken.
  // `pose` (the robot's, in the map frame) is required when recording by pose, `localized`
  // (the accepted match) when recording by localisation. `stamp_s` pairs the descriptor
  // with its image (AddImage).
  // Throws RecordingFull (counted as lost) once the recording holds what RecordingLimits
  // allow. Returns a warning for the caller to log when this descriptor brings the
  // recording to 90% of a limit (once a recording), else "".
  std::string Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                  const std::string& descriptor_type,
                  const std::optional<PlacePose>& pose = std::nullopt,
                  const std::optional<LocalizedPlace>& localized = std::nullopt,
                  double stamp_s = 0);
  // The encoded image (JPEG, PNG) the descriptor stamped `stamp_s` was described from, when
  // recording with save_images: kept with that descriptor whether it arrives before or
  // after it (an image no descriptor claims is forgotten after kEarlyImages others).
  void AddImage(double stamp_s, std::string encoded);
  // A descriptor that reached the recording but was not kept, and why (e.g. "no pose
  // received yet"): counted per cause for the stop's answer and diagnostics.
  void NoteLost(const std::string& cause);
  // Whether descriptors are taken: a recording runs, is not being saved, and no failed save
  // closed it.
  bool accepting() const { return recorder_.recording() && pending_reason_.empty() && !saving_; }
  // Why the recording is near or at its limits ("" when it is not), for diagnostics.
  std::string LimitProblem() const;

  struct Saved {
    ReferenceSet set;  // as written, for the caller to load
    std::string path;  // absolute path of the YAML
    std::string note;  // what the caller should know ("saved without images: ..."), or ""
  };
  // What reached the recording: descriptors received, those with the robot's pose (recording
  // by pose), and the losses by cause (those kept: count()).
  struct Counts {
    int received = 0, with_pose = 0;
    std::map<std::string, int> lost;  // cause -> descriptors
  };
  const Counts& counts() const { return counts_; }
  // "received 30 descriptors, 0 with a pose, 0 kept (lost: 30 no pose received yet)".
  std::string Summary() const;
  // Saves the recording, meant for `distance`, and ends it. Replaces an existing YAML only
  // if Start was asked to overwrite. Each refusal says what arrived (Summary()) and what to
  // do. Throws std::invalid_argument if no recording runs, if it holds no descriptor (the
  // recording is ended: nothing to keep) or if the set cannot be built (poses that
  // contradict the map), and std::runtime_error if writing fails; in those two cases the
  // recording is kept, closed to new descriptors, until a later Save succeeds or Discard.
  // With `loaded`, places by pose are associated with its places (`options`), and a set
  // whose poses contradict them (PlaceLayout::CheckPlacePoses) is refused before saving.
  Saved Save(DistanceMetric distance, const PlaceLayout* loaded = nullptr,
             const PlaceIndexOptions& options = {});

  // Save in three steps, so that a caller's lock is held only for the first and the last
  // (building and writing a large set takes a while, recognition must go on meanwhile):
  // BeginSave (under the lock) checks as Save does and closes the recording (it takes no
  // descriptor, and Start, Save, Discard refuse while it is being saved); RunSave (without
  // the lock) builds and writes the set, reading what the recording holds and changing
  // nothing of it; EndSave (under the lock) ends the recording, or keeps it pending, and
  // returns or throws what Save would. `loaded` is kept alive by the job.
  struct SaveJob {
    DistanceMetric distance = DistanceMetric::kEuclidean;
    std::shared_ptr<const PlaceLayout> loaded;  // may be null
    PlaceIndexOptions options;
    Saved saved;                // RunSave's result ...
    std::string error;          // ... or why it failed
    bool build_failed = false;  // the set could not be built (else: writing failed)
  };
  SaveJob BeginSave(DistanceMetric distance, std::shared_ptr<const PlaceLayout> loaded,
                    const PlaceIndexOptions& options = {});
  void RunSave(SaveJob& job) const;
  Saved EndSave(SaveJob job);
  bool saving() const { return saving_; }
  Saved Save(DistanceMetric distance, const ReferenceSets* loaded,
             const PlaceIndexOptions& options = {}) {
    return Save(distance, loaded ? &loaded->layout() : nullptr, options);
  }

  // Ends the recording and drops what it holds. Throws std::invalid_argument if no
  // recording runs, or while it is being saved.
  void Discard();

  // Throws std::invalid_argument if a set named `set_name` is being recorded: loading it
  // now would leave two sets of that name once the recording is saved.
  void CheckNotRecording(const std::string& set_name) const;

  bool recording() const { return recorder_.recording(); }
  const std::string& name() const { return recorder_.name(); }
  int count() const { return recorder_.count(); }  // descriptors recorded so far
  // Why the recording is closed ("" while it takes descriptors): its last save failed or
  // its poses contradict the map.
  const std::string& pending_reason() const { return pending_reason_; }

  // Adds lines on the running or pending recording (name, counts, why it is pending) to
  // `status`; nothing otherwise.
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const;

 private:
  const DataDirectory* data_dir_;
  RecordingLimits limits_;
  std::set<std::string> keep_;
  ReferenceRecorder recorder_;
  int64_t bytes_ = 0;          // the rows' floats and the images kept
  bool limit_warned_ = false;  // the 90% warning was given
  bool saving_ = false;        // between BeginSave and EndSave
  bool overwrite_ = false;  // the recording may replace a set on disk
  std::string descriptor_type_;
  Counts counts_;
  std::string pending_reason_;  // the failed save's message while the recording is closed
  // save_images: per recorded row its stamp and encoded image ("" until it arrives), and
  // images that came before their descriptor.
  static constexpr size_t kEarlyImages = 32;
  bool save_images_ = false;
  std::vector<double> stamps_;
  std::vector<std::string> images_;
  std::deque<std::pair<double, std::string>> early_images_;
  // Ends the recording and forgets its rows and images (its counts stay, for the answer).
  void End();
};

}  // namespace bsf_vpr
