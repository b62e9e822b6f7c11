// Service handlers of the fusion node. Each answers success=false with a message on any
// error and leaves the loaded reference sets as they were; none can take the node down.
#include <chrono>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/fusion/fusion_node.h"
#include "src/ros/map/set_loading.h"

namespace bsf_vpr {

bool FusionNode::OnList(ListReferenceSets::Request&, ListReferenceSets::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const StoredReferenceSet& s : recognizer_.map().sets()) {
    res.sets.push_back(ToInfoMsg(s));
    const ShardSet* held = combiner_ ? combiner_->SetInfo(s.name()) : nullptr;
    if (held) {  // the combiner holds the layout; the shard, the rows
      ReferenceSetInfo& info = res.sets.back();
      info.dimension = held->dimension;
      info.memory_bytes = held->memory_bytes;
      info.storage = held->storage;
      info.shard = combiner_->shard_name(combiner_->OwnerOf(s.name()));
    }
  }
  res.num_places = recognizer_.map().num_places();
  return true;
}

// How long a routed load or unload waits for the shard's new shard_info.
constexpr double kShardInfoWaitS = 10.0;

template <typename Service>
bool FusionNode::RouteToShard(int shard, const std::string& service, Service* srv,
                              std::string* message) {
  std::string name;
  uint64_t infos = 0, refusals = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    name = combiner_->shard_name(shard);
    infos = combiner_->info_count(shard);
    refusals = combiner_->refusal_count(shard);
    combiner_->ExpectChange(shard);
  }
  if (!ros::service::call(name + "/" + service, *srv)) {
    *message = "shard " + name + " did not answer " + service;
    return false;
  }
  if (!srv->response.success) {
    *message = "shard " + name + ": " + srv->response.message;
    return false;
  }
  // Polls `ready` under the lock until it holds or the deadline passes (the shard_info
  // arrives on the node's own queue).
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(kShardInfoWaitS);
  const auto wait_for = [&](const auto& ready) {
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (ready()) return true;
      }
      if (ros::WallTime::now() >= deadline) return false;
      ros::WallDuration(0.01).sleep();
    }
  };
  const auto taken = [&] { return combiner_->info_count(shard) > infos; };
  // The shard published its new sets before answering: wait for the map to take them, or
  // to refuse them (a set that cannot share the map with the other shards' sets).
  if (!wait_for([&] { return taken() || combiner_->refusal_count(shard) > refusals; })) {
    *message = srv->response.message + ", but its new shard_info has not reached this node in " +
               std::to_string(static_cast<int>(kShardInfoWaitS)) + " s (see diagnostics)";
    return false;
  }
  std::vector<std::string> added;
  std::string refusal;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (taken()) {
      *message = srv->response.message;
      return true;
    }
    added = combiner_->RefusedNewSets(shard);
    refusal = combiner_->refusal(shard);
  }
  // Take the shard back to the sets the map holds (without the lock: a call), and answer
  // once they are back in the map (nothing refused).
  for (const std::string& set : added) {
    UnloadReferenceSet undo;
    undo.request.name = set;
    ros::service::call(name + "/" + names::kUnloadReferenceSetService, undo);
  }
  if (!added.empty()) wait_for(taken);
  *message = "the map refused shard " + name + "'s new sets (" + refusal + ")" +
             (added.empty() ? "" : "; unloaded again from the shard");
  return false;
}

bool FusionNode::OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res) {
  // Runs on the load queue's own thread: the files are read without the lock, so
  // descriptors keep flowing meanwhile; only adding the set takes it (and, with
  // first_stage pca, building the index for the new map: seconds for a large map).
  if (combiner_) {
    // Routed to the shard asked for, or the one holding the fewest places; the path is
    // below that shard's data directory.
    int shard = -1;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (int k = 0; k < combiner_->num_shards(); ++k) {
        const std::string& name = combiner_->shard_name(k);
        if (!req.shard.empty() && (name == req.shard || name == nh_.resolveName(req.shard))) {
          shard = k;
        }
      }
      if (req.shard.empty()) shard = combiner_->LeastLoaded();
      if (!req.name.empty() && combiner_->OwnerOf(req.name) >= 0) {
        res.success = false;
        res.message = "a reference set named " + QuotedForMessage(req.name) +
                      " is already loaded, on shard " +
                      combiner_->shard_name(combiner_->OwnerOf(req.name));
        return true;
      }
    }
    if (shard < 0) {
      res.success = false;
      res.message = req.shard.empty()
                        ? "no shard has published its sets yet"
                        : "no shard named " + QuotedForMessage(req.shard) + " (parameter shards)";
    } else {
      LoadReferenceSet forward;
      forward.request = req;
      forward.request.shard.clear();
      res.success = RouteToShard(shard, names::kLoadReferenceSetService, &forward, &res.message);
    }
    if (!res.success) ROS_WARN("bsf_vpr: load_reference_set refused: %s", res.message.c_str());
    return true;
  }
  try {
    if (!req.shard.empty()) {
      throw std::invalid_argument("shard " + QuotedForMessage(req.shard) +
                                  " given, but this node fuses no shards (parameter shards)");
    }
    ReferenceSet set = ReadRequestedSet(data_dir_.get(), req);
    std::lock_guard<std::mutex> lock(mutex_);
    TakeSetDistance(set, data_dir_->Relative(req.path), &params_, &recognizer_);
    recording_->CheckNotRecording(set.name);
    const std::string name = set.name;
    const int places = set.size();
    recognizer_.AddReferenceSet(std::move(set));
    PrepareFirstStage();
    CheckDescriptorFormat();
    res.success = true;
    res.message = "loaded '" + name + "' (" + std::to_string(places) + " places)";
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_WARN("bsf_vpr: load_reference_set refused: %s", e.what());
  }
  return true;
}

bool FusionNode::OnUnload(UnloadReferenceSet::Request& req, UnloadReferenceSet::Response& res) {
  if (combiner_) {
    int shard = -1;
    try {
      std::lock_guard<std::mutex> lock(mutex_);
      shard = combiner_->OwnerOf(req.name);
      if (shard < 0) {
        throw std::invalid_argument("no shard holds a reference set named " +
                                    QuotedForMessage(req.name));
      }
      recognizer_.CheckRemovable(req.name);  // e.g. the method nn:<set> needs it
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
      return true;
    }
    UnloadReferenceSet forward;
    forward.request = req;
    res.success = RouteToShard(shard, names::kUnloadReferenceSetService, &forward, &res.message);
    if (res.success) {
      std::lock_guard<std::mutex> lock(mutex_);
      counters_.Forget(req.name);
    }
    return true;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    if (recognizer_.map().IndexOf(req.name) < 0) {
      throw std::invalid_argument("no reference set named " + QuotedForMessage(req.name) +
                                  " is loaded");
    }
    recognizer_.RemoveReferenceSet(req.name);
    counters_.Forget(req.name);
    PrepareFirstStage();
    CheckDescriptorFormat();
    res.success = true;
    res.message = "unloaded '" + req.name + "'";
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

void FusionNode::QueryShards(QueryPlace::Request& req, QueryPlace::Response& res) {
  // Each shard's distances through its get_distances service (without the lock: the
  // shards answer while descriptors stream in), then the fusion, the state untouched.
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::string> shards;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (int k = 0; k < combiner_->num_shards(); ++k) shards.push_back(combiner_->shard_name(k));
  }
  std::vector<GetShardDistances> calls(shards.size());
  std::vector<const ShardDistances*> answers(shards.size(), nullptr);
  for (size_t k = 0; k < shards.size(); ++k) {
    calls[k].request.descriptor = req.descriptor;
    if (ros::service::call(shards[k] + "/" + names::kShardDistancesService, calls[k])) {
      answers[k] = &calls[k].response.distances;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ShardCombiner::Query query;
  std::string error;
  if (!combiner_->Assemble(answers, &query, &error)) throw std::invalid_argument(error);
  const Recognition r = recognizer_.RecognizeDistances(query.distances, false);
  res.belief.header = req.descriptor.header;
  ToBeliefMsg(r, recognizer_, params_.belief_top_k, &res.belief);
  res.belief.processing_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool FusionNode::OnQuery(QueryPlace::Request& req, QueryPlace::Response& res) {
  if (combiner_) {
    try {
      QueryShards(req, res);
      res.success = true;
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    return true;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    const auto start = std::chrono::steady_clock::now();
    const Recognition r = recognizer_.Recognize(DescriptorView(req.descriptor), false);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    res.belief.header = req.descriptor.header;
    ToBeliefMsg(r, recognizer_, params_.belief_top_k, &res.belief);
    res.belief.processing_time = seconds;
    res.success = true;
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

bool FusionNode::OnStatistics(GetSelectionStatistics::Request& req,
                              GetSelectionStatistics::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  res.queries = counters_.queries();
  for (const StoredReferenceSet& s : recognizer_.map().sets()) {
    res.sets.push_back(counters_.Usage(s.name()));
  }
  if (req.reset) counters_.Reset();
  return true;
}

bool FusionNode::OnStartRecording(StartRecording::Request& req, StartRecording::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    if (combiner_) {
      throw std::invalid_argument(
          "this node fuses shards and sees no descriptors: record with a fusion node of its "
          "own sets, then load the recorded set on a shard (load_reference_set with shard)");
    }
    const RecordingPlaces places =
        ParseRecordingPlaces(req.places.empty() ? "sequential" : req.places);
    if (places == RecordingPlaces::kPose && params_.pose_source == PoseSource::kNone) {
      throw std::invalid_argument(
          "recording by pose needs the robot's pose: set pose_source to tf or topic");
    }
    recording_->Start(req.name, req.condition, req.overwrite, recognizer_.map(), places,
                      req.save_images);
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
  std::lock_guard<std::mutex> lock(mutex_);
  // Also in a refusal: what arrived and what is kept.
  res.num_descriptors = recording_->count();
  res.num_received = recording_->counts().received;
  try {
    if (req.discard) {
      const std::string summary = recording_->recording() ? recording_->Summary() : "";
      recording_->Discard();
      FollowRecordingImages();
      res.success = true;
      res.message = "discarded the recording: " + summary;
      return true;
    }
    PlaceIndexOptions places = params_.places;
    places.place_spacing_m = PlaceSpacing();
    const std::string summary = recording_->Summary();
    Recording::Saved saved =
        recording_->Save(recognizer_.options().metric, &recognizer_.map(), places);
    FollowRecordingImages();
    res.path = saved.path;
    res.num_places = saved.set.size();
    const std::string what = "saved " + std::to_string(res.num_places) + " place(s) to " +
                             res.path + " (" + summary + ")" +
                             (saved.note.empty() ? "" : "; " + saved.note);
    try {
      recognizer_.AddReferenceSet(std::move(saved.set));
      PrepareFirstStage();
      CheckDescriptorFormat();
    } catch (const std::exception& e) {
      res.success = true;
      res.message = what + " but did not load them: " + e.what();
      ROS_WARN("bsf_vpr: %s", res.message.c_str());
      return true;
    }
    res.success = true;
    res.message = what + " and loaded them";
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    FollowRecordingImages();  // a stop that ended the recording, or closed it
    ROS_WARN("bsf_vpr: stop_recording: %s", e.what());
  }
  return true;
}

}  // namespace bsf_vpr
