#include "src/ros/fusion/recording.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "bsf_vpr/io/reference_set_io.h"

namespace bsf_vpr {
namespace {

// The YAML a recording named `name` is saved to, below `dir`. Throws std::invalid_argument
// for a name that SetNameProblem refuses (the rule of every set's name) or that is not a
// plain relative path (an empty, '.' or '..' part): the name is the set's and its files'.
std::string RecordingPath(const DataDirectory& dir, const std::string& name) {
  const std::string problem = SetNameProblem(name);
  if (!problem.empty()) throw std::invalid_argument(problem);
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
  return dir.Relative(name + ".yaml");
}

// The cause a descriptor with a broken robot pose is counted under (Counts::lost).
constexpr char kBadPoseCause[] = "robot pose not finite or out of bounds";

void CheckRecording(const ReferenceRecorder& recorder, bool saving) {
  if (!recorder.recording()) throw std::invalid_argument("no recording is running");
  if (saving) {
    throw std::invalid_argument("the recording '" + recorder.name() +
                                "' is being saved (stop_recording); wait for its answer");
  }
}

std::string Megabytes(int64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f MB", bytes / 1e6);
  return text;
}

}  // namespace

void Recording::Start(const std::string& name, const std::string& condition, bool overwrite,
                      const PlaceLayout& loaded, RecordingPlaces places, bool save_images) {
  if (!data_dir_) {
    throw std::invalid_argument("no data directory is configured (parameter data_directory)");
  }
  if (recorder_.recording()) {
    CheckRecording(recorder_, saving_);
    if (!pending_reason_.empty()) {
      throw std::invalid_argument("the recording '" + recorder_.name() +
                                  "' is pending: its stop failed (" + pending_reason_ +
                                  "); call stop_recording to save it again, or stop_recording "
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
  save_images_ = save_images;
  bytes_ = 0;
  limit_warned_ = false;
}

std::string Recording::Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                           const std::string& descriptor_type, const std::optional<PlacePose>& pose,
                           const std::optional<LocalizedPlace>& localized, double stamp_s) {
  if (!pending_reason_.empty()) {
    throw std::invalid_argument("the recording '" + recorder_.name() +
                                "' is pending after a failed stop and takes no descriptor");
  }
  if (saving_) {
    throw std::invalid_argument("the recording '" + recorder_.name() +
                                "' is being saved and takes no descriptor");
  }
  const int64_t row_bytes = static_cast<int64_t>(descriptor.size() * sizeof(float));
  if (recorder_.recording() &&
      (recorder_.count() >= limits_.max_descriptors || bytes_ + row_bytes > limits_.max_bytes)) {
    NoteLost("refused: the recording is full");
    throw RecordingFull("the recording '" + recorder_.name() + "' is full (" +
                        std::to_string(recorder_.count()) + " descriptors, " + Megabytes(bytes_) +
                        "; recording_max_descriptors " + std::to_string(limits_.max_descriptors) +
                        ", recording_max_megabytes " + Megabytes(limits_.max_bytes) +
                        "): this descriptor is not recorded; stop_recording saves what it holds");
  }
  // A broken pose (a localiser that lost itself, a garbage message) would become the place's
  // pose and refuse the whole set at the stop: its descriptor is left out instead, counted
  // under one cause whatever the value (the message names it).
  const std::string pose_problem = pose ? PoseProblem(*pose) : "";
  if (!pose_problem.empty() && recorder_.recording()) {
    NoteLost(kBadPoseCause);
    throw std::invalid_argument("the robot's pose for this descriptor " + pose_problem +
                                "; the descriptor is not recorded");
  }
  try {
    recorder_.Add(descriptor, pose, localized);
  } catch (const std::invalid_argument& e) {
    if (recorder_.recording()) NoteLost(e.what());
    throw;
  }
  ++counts_.received;
  counts_.with_pose += pose.has_value();
  bytes_ += row_bytes;
  if (!descriptor_type.empty()) descriptor_type_ = descriptor_type;
  if (save_images_) {
    stamps_.push_back(stamp_s);
    images_.emplace_back();
    for (auto it = early_images_.begin(); it != early_images_.end(); ++it) {
      if (it->first == stamp_s) {
        bytes_ += static_cast<int64_t>(it->second.size());
        images_.back() = std::move(it->second);
        early_images_.erase(it);
        break;
      }
    }
  }
  // 90% of a limit: said once a recording.
  if (limit_warned_ || LimitProblem().empty()) return "";
  limit_warned_ = true;
  return "the recording '" + recorder_.name() + "' is at 90% of its limits (" + LimitProblem() +
         "): stop_recording soon, or it refuses descriptors";
}

std::string Recording::LimitProblem() const {
  if (!recorder_.recording()) return "";
  const int64_t n = recorder_.count();
  if (10 * n < 9 * limits_.max_descriptors && 10 * bytes_ < 9 * limits_.max_bytes) return "";
  const bool full = n >= limits_.max_descriptors || bytes_ >= limits_.max_bytes;
  return std::string(full ? "full: " : "") + std::to_string(n) + " of recording_max_descriptors " +
         std::to_string(limits_.max_descriptors) + ", " + Megabytes(bytes_) +
         " of recording_max_megabytes " + Megabytes(limits_.max_bytes);
}

void Recording::AddImage(double stamp_s, std::string encoded) {
  if (!accepting() || !save_images_) return;
  // The descriptor came first: one of the latest rows (the ingest is at most a few behind).
  const size_t first = stamps_.size() > kEarlyImages ? stamps_.size() - kEarlyImages : 0;
  for (size_t k = stamps_.size(); k-- > first;) {
    if (stamps_[k] == stamp_s && images_[k].empty()) {
      bytes_ += static_cast<int64_t>(encoded.size());
      images_[k] = std::move(encoded);
      return;
    }
  }
  early_images_.emplace_back(stamp_s, std::move(encoded));
  if (early_images_.size() > kEarlyImages) early_images_.pop_front();
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
  if (save_images_) {
    const auto with_image = std::count_if(images_.begin(), images_.end(),
                                          [](const std::string& i) { return !i.empty(); });
    s += ", " + std::to_string(with_image) + " with an image";
  }
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

Recording::Saved Recording::Save(DistanceMetric distance, const PlaceLayout* loaded,
                                 const PlaceIndexOptions& options) {
  // Not owned: the caller keeps `loaded` alive for the call.
  SaveJob job = BeginSave(
      distance, std::shared_ptr<const PlaceLayout>(std::shared_ptr<void>(), loaded), options);
  RunSave(job);
  return EndSave(std::move(job));
}

Recording::SaveJob Recording::BeginSave(DistanceMetric distance,
                                        std::shared_ptr<const PlaceLayout> loaded,
                                        const PlaceIndexOptions& options) {
  CheckRecording(recorder_, saving_);
  if (recorder_.count() == 0) {
    // Nothing to keep: the recording ends, and the answer says what arrived.
    const std::string what = "nothing saved: recording '" + recorder_.name() + "' " + Summary();
    End();
    throw std::invalid_argument(what + "; the recording is ended: fix the cause and start again");
  }
  RecordingPath(*data_dir_, recorder_.name());  // checked at Start; refuses as Save did
  SaveJob job;
  job.distance = distance;
  job.loaded = std::move(loaded);
  job.options = options;
  saving_ = true;
  return job;
}

void Recording::RunSave(SaveJob& job) const {
  // Reads the recording only: nothing of it changes while saving_ (Add, AddImage, Start,
  // Discard and another save refuse or ignore), so this needs no lock.
  const std::string path = RecordingPath(*data_dir_, recorder_.name());
  ReferenceRecorder::Map map;
  map.options = job.options;
  if (job.loaded) map.place_poses = job.loaded->place_poses();
  std::vector<int> source;
  try {
    job.saved.set = recorder_.Build(descriptor_type_, map, &source);
    job.saved.set.distance = ToString(job.distance);
    if (job.loaded) {
      job.loaded->CheckPlacePoses(job.saved.set.name, job.saved.set.place_ids, job.saved.set.poses);
    }
  } catch (const std::exception& e) {
    job.error = std::string("the recording cannot be saved: ") + e.what();
    job.build_failed = true;
    return;
  }
  try {
    // Each place's image, "" where none came with its descriptor: the set keeps those that
    // came (an image is never given to another place, nor the whole set saved without).
    std::vector<std::string> images;
    int missing = 0;
    if (save_images_) {
      for (int row : source) {
        images.push_back(images_[static_cast<size_t>(row)]);
        missing += images.back().empty();
      }
    }
    SaveOptions options;
    options.replace = overwrite_;
    options.images = save_images_ ? &images : nullptr;
    options.keep = keep_;
    SavedImages saved = SaveReferenceSet(*data_dir_, job.saved.set, path, options);
    job.saved.set.images = std::move(saved.images);
    job.saved.set.image_files = std::move(saved.image_files);
    if (missing > 0) {
      job.saved.note = "saved " + std::to_string(source.size() - missing) + " of its " +
                       std::to_string(source.size()) +
                       " places with an image: " + std::to_string(missing) +
                       " had no camera image with the descriptor's stamp (recorded before the "
                       "image subscription connected, or is the fusion node's image topic the "
                       "camera's?)";
    }
  } catch (const std::exception& e) {
    job.error = std::string("saving failed: ") + e.what();
    return;
  }
  job.saved.path = data_dir_->path() + "/" + path;
}

Recording::Saved Recording::EndSave(SaveJob job) {
  saving_ = false;
  if (job.error.empty()) {
    End();
    return std::move(job.saved);
  }
  // A save that fails keeps the recording, closed.
  pending_reason_ = job.error;
  const std::string why =
      job.error + "; " + Summary() +
      "; the recording is kept and takes no more descriptors: "
      "call stop_recording again to retry, or stop_recording {discard: true} to drop it";
  if (job.build_failed) throw std::invalid_argument(why);
  throw std::runtime_error(why);
}

void Recording::Discard() {
  CheckRecording(recorder_, saving_);
  End();
}

void Recording::End() {
  recorder_.Discard();
  pending_reason_.clear();
  stamps_.clear();
  images_.clear();
  early_images_.clear();
  bytes_ = 0;
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
    if (!pending_reason_.empty())
      status.add("recording pending after a failed stop", pending_reason_);
    status.addf("recording size", "%d descriptors of %ld, %s of %s", recorder_.count(),
                static_cast<long>(limits_.max_descriptors), Megabytes(bytes_).c_str(),
                Megabytes(limits_.max_bytes).c_str());
  }
}

}  // namespace bsf_vpr
