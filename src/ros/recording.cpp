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
}

void Recording::Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                    const std::string& descriptor_type, const std::optional<PlacePose>& pose,
                    const std::optional<LocalizedPlace>& localized) {
  recorder_.Add(descriptor, pose, localized);
  if (!descriptor_type.empty()) descriptor_type_ = descriptor_type;
}

Recording::Saved Recording::Save(DistanceMetric distance, const ReferenceMap* loaded,
                                 const PlaceIndexOptions& options) {
  CheckRecording(recorder_);
  const std::string path = RecordingPath(*data_dir_, recorder_.name());
  ReferenceRecorder::Map map;
  map.options = options;
  if (loaded) map.place_poses = loaded->place_poses();
  // Built, saved, and only then forgotten: a save that fails keeps the recording.
  Saved saved{recorder_.Build(descriptor_type_, map), ""};  // throws if empty
  saved.set.distance = ToString(distance);
  if (loaded) loaded->CheckPlacePoses(saved.set);
  try {
    SaveReferenceSet(*data_dir_, saved.set, path, overwrite_);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("saving failed, the recording of ") +
                             std::to_string(count()) +
                             " descriptors is kept (call again to retry, or discard): " + e.what());
  }
  recorder_.Discard();
  saved.path = data_dir_->path() + "/" + path;
  return saved;
}

void Recording::Discard() {
  CheckRecording(recorder_);
  recorder_.Discard();
}

void Recording::CheckNotRecording(const std::string& set_name) const {
  if (recorder_.recording() && recorder_.name() == set_name) {
    throw std::invalid_argument("a reference set named '" + set_name + "' is being recorded");
  }
}

void Recording::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  if (recorder_.recording()) {
    status.addf("recording", "%s (%d descriptors, places by %s)", recorder_.name().c_str(),
                recorder_.count(), ToString(recorder_.places()).c_str());
  }
}

}  // namespace bsf_vpr
