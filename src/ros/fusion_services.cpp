// Service handlers of the fusion node. Each answers success=false with a message on any
// error and leaves the loaded reference sets as they were; none can take the node down.
#include <chrono>
#include <filesystem>

#include "bsf_vpr/core/file_util.h"
#include "bsf_vpr/core/reference_set_io.h"
#include "conversions.h"
#include "fusion_node.h"

namespace bsf_vpr {

bool FusionNode::OnList(ListReferenceSets::Request&, ListReferenceSets::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const ReferenceSet& s : recognizer_.map().sets()) res.sets.push_back(ToInfoMsg(s));
  res.num_places = recognizer_.map().num_places();
  return true;
}

bool FusionNode::OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res) {
  try {
    // Read the files without holding the lock: descriptors keep flowing meanwhile.
    const std::string path = ResolveBelowDirectory(params_.data_directory, req.path);
    ReferenceSet set = LoadEntry({req.name, path, req.condition}, params_.data_directory);
    std::lock_guard<std::mutex> lock(mutex_);
    if (recorder_.recording() && recorder_.name() == set.name) {
      throw std::invalid_argument("a reference set named '" + set.name + "' is being recorded");
    }
    const std::string name = set.name;
    const int places = set.size();
    recognizer_.AddReferenceSet(std::move(set));
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
    recognizer_.RemoveReferenceSet(req.name);
    selected_count_.erase(req.name);
    best_count_.erase(req.name);
    supplied_count_.erase(req.name);
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
  res.queries = total_processed_;
  auto count = [](const std::map<std::string, long>& m, const std::string& k) {
    const auto it = m.find(k);
    return it == m.end() ? 0L : it->second;
  };
  for (const ReferenceSet& s : recognizer_.map().sets()) {
    ReferenceSetUsage u;
    u.name = s.name;
    u.selected = count(selected_count_, s.name);
    u.best = count(best_count_, s.name);
    u.supplied_match = count(supplied_count_, s.name);
    u.selected_fraction =
        total_processed_ ? static_cast<double>(u.selected) / total_processed_ : 0.0;
    res.sets.push_back(u);
  }
  if (req.reset) {
    selected_count_.clear();
    best_count_.clear();
    supplied_count_.clear();
    total_processed_ = 0;
  }
  return true;
}

bool FusionNode::OnStartRecording(StartRecording::Request& req, StartRecording::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    if (recognizer_.map().IndexOf(req.name) >= 0) {
      throw std::invalid_argument("a reference set named '" + req.name + "' is already loaded");
    }
    // The file it will be saved to must lie below the data directory.
    ResolveBelowDirectory(params_.data_directory, req.name + ".yaml");
    recorder_.Start(req.name, req.condition, recognizer_.map().dimension());
    res.success = true;
    res.message = "recording '" + req.name + "'";
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
    if (!recorder_.recording()) throw std::invalid_argument("no recording is running");
    res.num_descriptors = recorder_.count();
    if (req.discard) {
      recorder_.Discard();
      res.success = true;
      res.message = "discarded " + std::to_string(res.num_descriptors) + " descriptors";
      return true;
    }
    const std::string path =
        ResolveBelowDirectory(params_.data_directory, recorder_.name() + ".yaml");
    ReferenceSet set = recorder_.Finish();  // throws (and keeps recording) if nothing arrived
    set.distance = ToString(params_.recognizer.metric);
    SaveReferenceSet(set, path);
    recognizer_.AddReferenceSet(std::move(set));
    res.success = true;
    res.path = path;
    res.message = "saved " + std::to_string(res.num_descriptors) + " descriptors to " + path +
                  " and loaded them";
    ROS_INFO("bsf_vpr: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

}  // namespace bsf_vpr
