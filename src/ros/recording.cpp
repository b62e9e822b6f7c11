#include "recording.h"

#include <stdexcept>

#include "bsf_vpr/core/reference_set_io.h"

namespace bsf_vpr {
namespace {

// The YAML a recording named `name` is saved to, below `dir`. Throws std::invalid_argument
// for a name that is not a plain path of printable parts.
std::string RecordingPath(const DataDirectory& dir, const std::string& name) {
  if (name.empty()) throw std::invalid_argument("a recording needs a non-empty name");
  size_t start = 0;
  for (;;) {
    const size_t slash = name.find('/', start);
    const std::string part = name.substr(start, slash == std::string::npos ? slash : slash - start);
    if (part.empty() || part == "." || part == "..") {
      throw std::invalid_argument("recording name " + QuotedForMessage(name) +
                                  " has an empty, '.' or '..' part");
    }
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  return dir.Relative(name + ".yaml");  // refuses control characters and invalid UTF-8
}

void CheckRecording(const ReferenceRecorder& recorder) {
  if (!recorder.recording()) throw std::invalid_argument("no recording is running");
}

}  // namespace

void Recording::Start(const std::string& name, const std::string& condition, bool overwrite,
                      const ReferenceMap& loaded, RecordingPlaces places) {
  if (!data_dir_) {
    throw std::invalid_argument("no data directory is configured (parameter data_directory)");
  }
  if (recorder_.recording()) {
    if (!pending_reason_.empty()) {
      throw std::invalid_argument(
          "the recording '" + recorder_.name() + "' is pending: its stop failed (" +
          pending_reason_ + "); call stop_recording to save it again, or stop_recording "
          "{discard: true} to drop it, before starting another");
    }
    throw std::invalid_argument("the recording '" + recorder_.name() + "' is running (" +
                                Summary() + "); stop it first (stop_recording)");
  }
  const std::string path = RecordingPath(*data_dir_, name);
  if (loaded.IndexOf(name) >= 0) {
    throw std::invalid_argument("a reference set named '" + name + "' is already loaded");
  }
  if (data_dir_->Exists(path) && !overwrite) {
    throw std::invalid_argument("'" + path + "' exists in the data directory; choose another " +
                                "name, or set overwrite to replace it");
  }
  if (places == RecordingPlaces::kLocalized && loaded.num_sets() == 0) {
    throw std::invalid_argument(
        "recording by localisation needs a loaded reference set to "
        "localise against");
  }
  recorder_.Start(name, condition, loaded.dimension(), places);  // refuses a second one
  overwrite_ = overwrite;
  descriptor_type_.clear();
  counts_ = Counts();
  pending_reason_.clear();
}

void Recording::Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                    const std::string& descriptor_type, const std::optional<PlacePose>& pose,
                    const std::optional<LocalizedPlace>& localized) {
  if (!pending_reason_.empty()) {
    throw std::invalid_argument("the recording '" + recorder_.name() +
                                "' is pending after a failed stop and takes no descriptor");
  }
  try {
    recorder_.Add(descriptor, pose, localized);
  } catch (const std::invalid_argument& e) {
    if (recorder_.recording()) NoteLost(e.what());
    throw;
  }
  ++counts_.received;
  counts_.with_pose += pose.has_value();
  if (!descriptor_type.empty()) descriptor_type_ = descriptor_type;
}

void Recording::NoteLost(const std::string& cause) {
  if (!accepting()) return;
  ++counts_.received;
  ++counts_.lost[cause];
}

std::string Recording::Summary() const {
  std::string s = "received " + std::to_string(counts_.received) + " descriptor(s)";
  if (recorder_.places() == RecordingPlaces::kPose) {
    s += ", " + std::to_string(counts_.with_pose) + " with a pose of the robot";
  }
  s += ", " + std::to_string(recorder_.count()) + " kept";
  if (!counts_.lost.empty()) {
    s += " (lost:";
    bool first = true;
    for (const auto& [cause, n] : counts_.lost) {
      s += (first ? " " : "; ") + std::to_string(n) + " " + cause;
      first = false;
    }
    s += ")";
  }
  return s;
}

Recording::Saved Recording::Save(DistanceMetric distance, const ReferenceMap* loaded,
                                 const PlaceIndexOptions& options) {
  CheckRecording(recorder_);
  if (recorder_.count() == 0) {
    // Nothing to keep: the recording ends, and the answer says what arrived.
    const std::string what = "nothing saved: recording '" + recorder_.name() + "' " + Summary();
    recorder_.Discard();
    pending_reason_.clear();
    throw std::invalid_argument(what + "; the recording is ended: fix the cause and start again");
  }
  const std::string path = RecordingPath(*data_dir_, recorder_.name());
  ReferenceRecorder::Map map;
  map.options = options;
  if (loaded) map.place_poses = loaded->place_poses();
  // Built, saved, and only then forgotten: a save that fails keeps the recording, closed.
  const auto keep = [&](const std::string& why) {
    pending_reason_ = why;
    return why + "; " + Summary() + "; the recording is kept and takes no more descriptors: "
           "call stop_recording again to retry, or stop_recording {discard: true} to drop it";
  };
  Saved saved;
  try {
    saved.set = recorder_.Build(descriptor_type_, map);
    saved.set.distance = ToString(distance);
    if (loaded) loaded->CheckPlacePoses(saved.set);
  } catch (const std::exception& e) {
    throw std::invalid_argument(keep(std::string("the recording cannot be saved: ") + e.what()));
  }
  try {
    SaveReferenceSet(*data_dir_, saved.set, path, overwrite_);
  } catch (const std::exception& e) {
    throw std::runtime_error(keep(std::string("saving failed: ") + e.what()));
  }
  recorder_.Discard();
  pending_reason_.clear();
  saved.path = data_dir_->path() + "/" + path;
  return saved;
}

void Recording::Discard() {
  CheckRecording(recorder_);
  recorder_.Discard();
  pending_reason_.clear();
}

void Recording::CheckNotRecording(const std::string& set_name) const {
  if (recorder_.recording() && recorder_.name() == set_name) {
    throw std::invalid_argument("a reference set named '" + set_name + "' is being recorded");
  }
}

void Recording::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  if (recorder_.recording()) {
    status.addf("recording", "%s (places by %s): %s", recorder_.name().c_str(),
                ToString(recorder_.places()).c_str(), Summary().c_str());
    if (!pending_reason_.empty()) status.add("recording pending after a failed stop", pending_reason_);
  }
}

}  // namespace bsf_vpr
