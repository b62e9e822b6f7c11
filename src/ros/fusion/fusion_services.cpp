// Service handlers of the fusion node. Each answers success=false with a message on any
// error and leaves the loaded reference sets as they were; none can take the node down.
#include <chrono>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/map/set_loading.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/fusion/fusion_node.h"
#include "src/ros/map/configured_paths.h"

namespace bsf_vpr {
namespace {

// A request's package://PACKAGE/PATH resolved as a configured set's is (the package's
// folder), and still confined: it must then lie below the data directory `dir`, which
// every request is read below (a package's folder holds what its author shipped, not what a
// caller may read). Other paths, and requests for a shard (resolved on its computer), are
// returned unchanged. Throws std::invalid_argument naming the path, what it resolved to
// and the rule.
std::string ResolvedRequestPath(const LoadReferenceSet::Request& req, const DataDirectory* dir) {
  if (req.path.rfind("package://", 0) != 0 || !req.shard.empty() || dir == nullptr) {
    return req.path;
  }
  const std::string resolved = ResolveConfiguredPath(dir->path(), req.path);
  try {
    dir->Relative(resolved);  // the rule of every request's path
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(
        "path " + QuotedForMessage(req.path) + " is " + QuotedForMessage(resolved) + ": " +
        e.what() +
        "; load_reference_set reads only below it (reference_sets in the configuration may "
        "name package files; or copy the set into the data directory)");
  }
  return resolved;
}

}  // namespace

bool FusionNode::OnList(ListReferenceSets::Request&, ListReferenceSets::Response& res) {
  ToListResponse(map_->List(), &res);
  return true;
}

bool FusionNode::OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res) {
  // Runs on the load queue's own thread: the map reads the files (or the shard does)
  // without the node's lock, so descriptors keep flowing meanwhile.
  try {
    std::string name;  // once read: not to be recorded until it is in the map
    const MapBackend::SetCheck not_recorded = [this, &name](const std::string& set) {
      MutexLock lock(&mutex_);
      recording_->CheckNotRecording(set);
      busy_.Take(set, "loaded");
      name = set;
    };
    const auto loaded = [this, &name] {
      MutexLock lock(&mutex_);
      if (!name.empty()) busy_.Release(name, "loaded");
      AdoptLayout(map_->layout());
    };
    try {
      LoadRequest resolved = ToLoadRequest(req);
      resolved.path = ResolvedRequestPath(req, data_dir_.get());
      res.message = map_->Load(resolved, not_recorded);
    } catch (...) {
      loaded();
      throw;
    }
    loaded();
    res.success = true;
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_WARN("bsf_vpr: load_reference_set refused: %s", e.what());
  }
  return true;
}

bool FusionNode::OnUnload(UnloadReferenceSet::Request& req, UnloadReferenceSet::Response& res) {
  try {
    {
      MutexLock lock(&mutex_);
      decider_.CheckRemovable(req.name);  // e.g. the method nn:<set> needs it
      busy_.Take(req.name, "unloaded");   // no method may take it up meanwhile
    }
    const auto finish = [this, &req](bool unloaded) {
      MutexLock lock(&mutex_);
      if (unloaded) counters_.Forget(req.name);
      busy_.Release(req.name, "unloaded");
      AdoptLayout(map_->layout());
    };
    try {
      res.message = map_->Unload(req.name);
    } catch (...) {
      finish(false);
      throw;
    }
    finish(true);
    res.success = true;
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

bool FusionNode::OnQuery(QueryPlace::Request& req, QueryPlace::Response& res) {
  // On its own thread: the map's distances without the lock (a sharded map asks every
  // shard), then the decision, the state untouched.
  try {
    const auto start = std::chrono::steady_clock::now();
    MapBackend::Query query = map_->Ask(ToQueryDescriptor(req.descriptor));
    MutexLock lock(&mutex_);
    if (!AdoptLayout(query.layout)) {
      throw std::invalid_argument("the map's sets changed while the query was answered; ask again");
    }
    decider_.SetAcceptanceRule(query.acceptance_rule);
    const Recognition r = decider_.Decide(*layout_, query.distances, false);
    res.belief.header = req.descriptor.header;
    ToBeliefMsg(r, *layout_, decider_, params_.belief_top_k, &res.belief);
    res.belief.processing_time =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    res.success = true;
    // As on the descriptor topic: answered, with the warning (the topic's goes to the log and
    // diagnostics, the service's to its caller).
    const std::string mismatch = TypeMismatch(req.descriptor.descriptor_type, *layout_);
    if (!mismatch.empty()) {
      res.message = "answered, but " + mismatch + ": the distances compare unlike descriptors";
    }
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

bool FusionNode::OnStatistics(GetSelectionStatistics::Request& req,
                              GetSelectionStatistics::Response& res) {
  MutexLock lock(&mutex_);
  res.queries = counters_.queries();
  for (const SetLayout& s : layout_->sets()) res.sets.push_back(counters_.Usage(s.name));
  if (req.reset) counters_.Reset();
  return true;
}

bool FusionNode::OnStartRecording(StartRecording::Request& req, StartRecording::Response& res) {
  MutexLock lock(&mutex_);
  try {
    const std::string cannot = map_->CannotRecord();
    if (!cannot.empty()) throw std::invalid_argument(cannot);
    busy_.Check(req.name);
    const RecordingPlaces places =
        ParseRecordingPlaces(req.places.empty() ? "sequential" : req.places);
    if (places == RecordingPlaces::kPose && params_.pose_source == PoseSource::kNone) {
      throw std::invalid_argument(
          "recording by pose needs the robot's pose: set pose_source to tf or topic");
    }
    recording_->Start(req.name, req.condition, req.overwrite, *layout_, places, req.save_images);
    FollowRecordingImages();
    res.success = true;
    res.message = "recording '" + req.name + "', places by " + ToString(places);
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

bool FusionNode::OnStopRecording(StopRecording::Request& req, StopRecording::Response& res) {
  // The set is built and written without the lock (seconds for a long recording), so that
  // recognition goes on; the recording is closed meanwhile (Recording::BeginSave). A
  // subscription ended is shut down without the lock too: shutdown waits for its running
  // callback, which may be waiting for the lock.
  ros::Subscriber stopped;
  Recording::SaveJob job;
  std::string summary;
  try {
    {
      MutexLock lock(&mutex_);
      // Also in a refusal: what arrived and what is kept.
      // (Nothing when no recording runs: the counts of an ended one are not this answer's.)
      if (recording_->recording()) {
        res.num_descriptors = recording_->count();
        res.num_received = recording_->counts().received;
      }
      if (req.discard) {
        summary = recording_->recording() ? recording_->Summary() : "";
        try {
          recording_->Discard();
        } catch (...) {
          stopped = FollowRecordingImages();
          throw;
        }
        stopped = FollowRecordingImages();
        res.success = true;
        res.message = "discarded the recording: " + summary;
      } else {
        PlaceIndexOptions places = params_.places;
        places.place_spacing_m = PlaceSpacing();
        summary = recording_->Summary();
        try {
          job = recording_->BeginSave(map_->metric(), layout_, places);
        } catch (...) {
          stopped = FollowRecordingImages();  // a stop that ended the recording
          throw;
        }
        stopped = FollowRecordingImages();
      }
    }
    stopped.shutdown();
    if (req.discard) return true;
    // Without the lock: the save reads the closed recording only (BeginSave closed it under
    // the lock; nothing adds to it until EndSave), through a pointer the analysis does not
    // follow.
    Recording* const closed = recording_.get();
    closed->RunSave(job);
    Recording::Saved saved;
    {
      MutexLock lock(&mutex_);
      try {
        saved = recording_->EndSave(std::move(job));
      } catch (...) {
        stopped = FollowRecordingImages();  // kept, closed
        throw;
      }
      busy_.Hold(saved.set.name, "loaded");  // not to be loaded by another meanwhile
    }
    LoadRecorded(std::move(saved), summary, &res);
  } catch (const std::exception& e) {
    stopped.shutdown();
    res.success = false;
    res.message = e.what();
    ROS_WARN("bsf_vpr: stop_recording: %s", e.what());
  }
  return true;
}

void FusionNode::LoadRecorded(Recording::Saved saved, const std::string& summary,
                              StopRecording::Response* res) {
  res->path = saved.path;
  res->num_places = saved.set.size();
  const std::string name = saved.set.name;
  const std::string what = "saved " + std::to_string(res->num_places) + " place(s) to " +
                           res->path + " (" + summary + ")" +
                           (saved.note.empty() ? "" : "; " + saved.note);
  std::string not_loaded;
  try {
    map_->Add(std::move(saved.set), res->path);  // the map's own lock
  } catch (const std::exception& e) {
    not_loaded = e.what();
  }
  {
    MutexLock lock(&mutex_);
    busy_.Release(name, "loaded");
    AdoptLayout(map_->layout());
  }
  res->success = true;
  if (!not_loaded.empty()) {
    res->message = what + " but did not load them: " + not_loaded;
    ROS_WARN("bsf_vpr: %s", res->message.c_str());
    return;
  }
  res->message = what + " and loaded them";
  ROS_INFO("bsf_vpr: %s", res->message.c_str());
}

}  // namespace bsf_vpr
