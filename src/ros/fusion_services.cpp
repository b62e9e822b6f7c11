// Service handlers of the fusion node. Each answers success=false with a message on any
// error and leaves the loaded reference sets as they were; none can take the node down.
#include <chrono>

#include "bsf_vpr/core/data_directory.h"
#include "bsf_vpr/core/reference_set_io.h"
#include "conversions.h"
#include "fusion_node.h"

namespace bsf_vpr {

bool FusionNode::OnList(ListReferenceSets::Request&, ListReferenceSets::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const StoredReferenceSet& s : recognizer_.map().sets()) res.sets.push_back(ToInfoMsg(s));
  res.num_places = recognizer_.map().num_places();
  return true;
}

bool FusionNode::OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res) {
  // Runs on the load queue's own thread: the files are read without the lock, so
  // descriptors keep flowing meanwhile; only adding the set takes it (and, with
  // first_stage pca, building the index for the new map: seconds for a large map).
  try {
    if (!data_dir_) {
      throw std::invalid_argument("no data directory is configured (parameter data_directory)");
    }
    ReferenceSet set = LoadReferenceSetFile(*data_dir_, req.path, req.name);
    if (!req.condition.empty()) set.condition = req.condition;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!params_.distance_given() && recognizer_.map().num_sets() == 0 && !set.distance.empty()) {
      // No distance configured and nothing loaded yet: the first set's own distance.
      RecognizerOptions o = recognizer_.options();
      o.metric = ParseDistanceMetric(set.distance);
      recognizer_.SetOptions(o);
      params_.recognizer.metric = o.metric;
      ROS_INFO("bsf_vpr: distance %s, as the reference set '%s' declares", set.distance.c_str(),
               set.name.c_str());
    }
    CheckDistance(set, data_dir_->Relative(req.path));
    recording_->CheckNotRecording(set.name);
    const std::string name = set.name;
    const int places = set.size();
    recognizer_.AddReferenceSet(std::move(set));
    PrepareFirstStage();
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
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    if (recognizer_.map().IndexOf(req.name) < 0) {
      throw std::invalid_argument("no reference set named " + QuotedForMessage(req.name) +
                                  " is loaded");
    }
    recognizer_.RemoveReferenceSet(req.name);
    counters_.Forget(req.name);
    PrepareFirstStage();
    res.success = true;
    res.message = "unloaded '" + req.name + "'";
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

bool FusionNode::OnQuery(QueryPlace::Request& req, QueryPlace::Response& res) {
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
    const RecordingPlaces places =
        ParseRecordingPlaces(req.places.empty() ? "sequential" : req.places);
    if (places == RecordingPlaces::kPose && params_.pose_source == "none") {
      throw std::invalid_argument(
          "recording by pose needs the robot's pose: set pose_source to tf or topic");
    }
    recording_->Start(req.name, req.condition, req.overwrite, recognizer_.map(), places);
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
  try {
    res.num_descriptors = recording_->count();  // also in a refusal: what is kept
    if (req.discard) {
      recording_->Discard();
      res.success = true;
      res.message = "discarded " + std::to_string(res.num_descriptors) + " descriptors";
      return true;
    }
    PlaceIndexOptions places = params_.places;
    places.place_spacing_m = PlaceSpacing();
    Recording::Saved saved =
        recording_->Save(recognizer_.options().metric, &recognizer_.map(), places);
    res.path = saved.path;
    try {
      recognizer_.AddReferenceSet(std::move(saved.set));
      PrepareFirstStage();
    } catch (const std::exception& e) {
      res.success = true;
      res.message = "saved " + std::to_string(res.num_descriptors) + " descriptors to " + res.path +
                    " but did not load them: " + e.what();
      ROS_WARN("bsf_vpr: %s", res.message.c_str());
      return true;
    }
    res.success = true;
    res.message = "saved " + std::to_string(res.num_descriptors) + " descriptors to " + res.path +
                  " and loaded them";
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_WARN("bsf_vpr: stop_recording: %s", e.what());
  }
  return true;
}

}  // namespace bsf_vpr
