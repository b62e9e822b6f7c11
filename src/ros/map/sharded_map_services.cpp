#include "src/ros/map/sharded_map.h"

// ShardedMap: query_place, the routing of loads and unloads to the shards, the list of
// sets and the diagnostics.

#include <bsf_vpr/GetShardDistances.h>
#include <bsf_vpr/GetShardInfo.h>
#include <bsf_vpr/UnloadReferenceSet.h>

#include <algorithm>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/set_loading.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/map/sharded_map_parts.h"

namespace bsf_vpr {

namespace {

// Why a sharded map does not calibrate itself.
const char* const kCannotCalibrate =
    "not calibrated: a sharded map's combiner holds no descriptors to hold out (the threshold "
    "alone)";

}  // namespace

using namespace sharded;

MapBackend::Query ShardedMap::Ask(const QueryDescriptor& descriptor) {
  // Each shard's distances through its get_distances service, called at once and waited for
  // until one deadline (without the lock: the shards answer while descriptors stream in).
  std::vector<std::string> names;
  std::vector<std::shared_ptr<std::atomic<int>>> stalled;
  {
    MutexLock lock(&mutex_);
    for (const Shard& s : shards_) {
      names.push_back(s.name);
      stalled.push_back(s.stalled_calls);
    }
  }
  GetShardDistances request;
  request.request.descriptor = ToDescriptorMsg(descriptor);
  std::vector<std::unique_ptr<ShardCall<GetShardDistances>>> calls;
  for (size_t k = 0; k < names.size(); ++k) {
    calls.push_back(std::make_unique<ShardCall<GetShardDistances>>(
        names[k] + "/" + names::kShardDistancesService, request, stalled[k]));
  }
  const auto deadline = Deadline(options_.call_timeout_s());
  std::vector<const ShardDistances*> answers(names.size(), nullptr);
  for (size_t k = 0; k < names.size(); ++k) {
    const std::string why = calls[k]->Wait(deadline, options_.call_timeout_s());
    if (why.empty()) {
      answers[k] = &calls[k]->response().distances;
    } else {
      ROS_WARN_THROTTLE(5.0, "bsf_vpr: query_place: shard %s %s: answered without its sets",
                        names[k].c_str(), why.c_str());
    }
  }
  MutexLock lock(&mutex_);
  return Assemble(descriptor.header, Norm(descriptor), answers);
}

template <typename Service>
std::string ShardedMap::Route(int k, const std::string& service, Service* srv, double timeout_s) {
  std::string name;
  uint64_t infos = 0, refusals = 0;
  std::shared_ptr<std::atomic<int>> stalled;
  {
    MutexLock lock(&mutex_);
    Shard& shard = shards_.at(static_cast<size_t>(k));
    name = shard.name;
    infos = shard.info_count;
    refusals = shard.refusals;
    stalled = shard.stalled_calls;
    shard.change_expected = true;  // its next change of sets is not warned about as lost
  }
  const std::string why = CallShard(name + "/" + service, srv, stalled, timeout_s);
  if (!why.empty()) {
    throw std::invalid_argument("shard " + name + " " + why +
                                "; if it completes later, the map takes the shard's new sets "
                                "when its shard_info arrives (list_reference_sets)");
  }
  if (!srv->response.success) {
    throw std::invalid_argument("shard " + name + ": " + srv->response.message);
  }
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(kShardInfoWaitS);
  MutexLock lock(&mutex_);
  const Shard& shard = shards_[static_cast<size_t>(k)];
  const auto taken = [&] {
    mutex_.AssertHeld();
    return shard.info_count > infos;
  };
  // The shard published its new sets before answering: wait for the map to take them, or
  // to refuse them (a set that cannot share the map with the other shards' sets).
  if (!lock.AwaitUntil(infos_changed_, deadline, [&] {
        mutex_.AssertHeld();
        return taken() || shard.refusals > refusals;
      })) {
    throw std::invalid_argument(
        srv->response.message + ", but its new shard_info has not reached this node in " +
        std::to_string(static_cast<int>(kShardInfoWaitS)) + " s (see diagnostics)");
  }
  if (taken()) return srv->response.message;
  // Take the shard back to the sets the map holds (without the lock: a call), and answer
  // once they are back in the map (nothing refused).
  std::vector<std::string> added;
  if (shard.refused_info) {
    for (const ShardSet& s : shard.refused_info->sets) {
      bool held = false;
      if (shard.info) {
        for (const ShardSet& t : shard.info->sets) held = held || t.name == s.name;
      }
      if (!held) added.push_back(s.name);
    }
  }
  const std::string refusal = shard.refused;
  lock.Unlock();
  for (const std::string& set : added) {
    UnloadReferenceSet undo;
    undo.request.name = set;
    const std::string undone = CallShard(name + "/" + names::kUnloadReferenceSetService, &undo,
                                         stalled, options_.call_timeout_s());
    if (!undone.empty()) ROS_WARN("bsf_vpr: shard %s %s", name.c_str(), undone.c_str());
  }
  lock.Lock();
  if (!added.empty()) lock.AwaitUntil(infos_changed_, deadline, taken);
  throw std::invalid_argument("the map refused shard " + name + "'s new sets (" + refusal + ")" +
                              (added.empty() ? "" : "; unloaded again from the shard"));
}

std::string ShardedMap::Load(const LoadRequest& request, const SetCheck&) {
  // Routed to the shard asked for, or the one holding the fewest places; the path is below
  // that shard's data directory.
  int shard = -1;
  {
    MutexLock lock(&mutex_);
    for (size_t k = 0; k < shards_.size(); ++k) {
      const std::string& name = shards_[k].name;
      if (!request.shard.empty() &&
          (name == request.shard || name == nh_.resolveName(request.shard))) {
        shard = static_cast<int>(k);
      }
    }
    if (request.shard.empty()) shard = LeastLoaded();
    if (!request.name.empty() && OwnerOf(request.name) >= 0) {
      throw std::invalid_argument("a reference set named " + QuotedForMessage(request.name) +
                                  " is already loaded, on shard " +
                                  shards_[static_cast<size_t>(OwnerOf(request.name))].name);
    }
  }
  if (shard < 0) {
    throw std::invalid_argument(request.shard.empty()
                                    ? "no shard has published its sets yet"
                                    : "no shard named " + QuotedForMessage(request.shard) +
                                          " (parameter shards)");
  }
  LoadReferenceSet forward;
  forward.request = ToLoadRequestMsg(request);
  forward.request.shard.clear();
  return Route(shard, names::kLoadReferenceSetService, &forward,
               options_.sharding.shard_load_timeout);
}

std::string ShardedMap::Unload(const std::string& name) {
  int shard = -1;
  {
    MutexLock lock(&mutex_);
    shard = OwnerOf(name);
  }
  if (shard < 0) {
    throw std::invalid_argument("no shard holds a reference set named " + QuotedForMessage(name));
  }
  UnloadReferenceSet forward;
  forward.request.name = name;
  return Route(shard, names::kUnloadReferenceSetService, &forward, options_.call_timeout_s());
}

std::string ShardedMap::CannotRecord() const {
  return "this node fuses shards and sees no descriptors: record with a fusion node of its "
         "own sets, then load the recorded set on a shard (load_reference_set with shard)";
}

std::string ShardedMap::Add(ReferenceSet, const std::string&) {
  throw std::invalid_argument(CannotRecord());
}

SetList ShardedMap::List() const {
  // This map holds the layout; the shard, the rows (a shard's refused sets are in its
  // refused_info, not in info).
  MutexLock lock(&mutex_);
  SetList out;
  for (const Shard& shard : shards_) {
    if (!shard.info) continue;
    for (const ShardSet& s : shard.info->sets) {
      SetSummary info;
      info.layout = LayoutFromShardSetMsg(s);
      info.memory_bytes = s.memory_bytes;
      info.storage = s.storage;
      info.shard = shard.name;
      out.sets.push_back(info);
    }
  }
  out.num_places = layout_->num_places();
  out.calibration = calibration_asked_ ? kCannotCalibrate
                                       : "none asked for (max_false_accept_rate 0: the threshold "
                                         "alone)";
  return out;
}

void ShardedMap::SetCalibration(std::optional<CalibrationRequest> request) {
  MutexLock lock(&mutex_);
  calibration_asked_ = request.has_value();
}

std::string ShardedMap::MissingSummaryLocked() const {
  std::string out;
  for (size_t k = 0; k < shards_.size(); ++k) {
    const Shard& shard = shards_[k];
    std::string why;
    if (!shard.info) {
      why = "no shard_info yet";
    } else if (!shard.refused.empty()) {
      why = "its sets refused: " + shard.refused;
    } else if (!shard.info->sets.empty() && (join_.counts(static_cast<int>(k)).missing ||
                                             shard.distances_sub.getNumPublishers() == 0)) {
      why = SetNames(shard.info.get());
    }
    if (!why.empty()) out += (out.empty() ? "" : "; ") + shard.name + " (" + why + ")";
  }
  return out;
}

void ShardedMap::SetJoint(std::optional<JointKind> kind, const JointOptions& /*options*/) {
  MutexLock lock(&mutex_);
  joint_kind_ = kind;
}

std::string ShardedMap::Problem() const {
  MutexLock lock(&mutex_);
  const std::string missing = MissingSummaryLocked();
  return missing.empty() ? "" : "deciding without shard(s) " + missing;
}

StatusValues ShardedMap::Diagnose() const {
  MutexLock lock(&mutex_);
  StatusValues status;
  const auto add = [&status](const std::string& key, const std::string& value) {
    status.emplace_back(key, value);
  };
  // The shards' own: this map computes no distances.
  add("first stage", ToString(FirstStageKind::kExact));
  add("joint representation",
      !joint_kind_ ? std::string("none asked for")
      : joint_used_.empty()
          ? "none: no shard serves the " + ToString(*joint_kind_) +
                " of two or more sets over every place (shard parameter fusion_joint)"
          : ToString(*joint_kind_) + " from shard " + joint_used_);
  add("calibration", calibration_asked_ ? kCannotCalibrate : "none asked for");
  add("shards", std::to_string(shards_.size()));
  add("map layouts taken", std::to_string(layouts_));
  add("queries decided", std::to_string(decided_));
  add("decided without some shard", std::to_string(decided_partial_));
  // Heard, but no shard's answer came within shard_timeout_s (lost on the way, e.g. from a
  // shard's full publisher queue while this node stalled): no belief for them.
  add("queries no shard answered", std::to_string(join_.unanswered()));
  for (size_t k = 0; k < shards_.size(); ++k) {
    const Shard& shard = shards_[k];
    const Join::ShardCounts& counts = join_.counts(static_cast<int>(k));
    std::string state;
    if (!shard.refused.empty()) state = "sets refused: " + shard.refused + "; ";
    if (!shard.info) {
      state += "no shard_info yet";
    } else if (shard.distances_sub.getNumPublishers() == 0) {
      state += "not publishing (" + SetNames(shard.info.get()) + " missing)";
    } else if (counts.missing) {
      state += "missing for " + std::to_string(static_cast<int>(NowS() - counts.missing_since_s)) +
               " s (" + SetNames(shard.info.get()) + ")";
    } else {
      state += "answering: " + SetNames(shard.info.get());
    }
    if (!shard.lost.empty()) state += "; lost at its last change: " + shard.lost;
    if (shard.unconfirmed) state += "; a shard_info waits for the shard to confirm it";
    if (shard.foreign_infos > 0) {
      state += "; " + std::to_string(shard.foreign_infos) +
               " shard_info refused: published by another node (last " + shard.last_foreign + ")";
    }
    if (shard.corrected_infos > 0) {
      state += "; " + std::to_string(shard.corrected_infos) +
               " shard_info other than the shard's own answer (its answer taken)";
    }
    if (*shard.stalled_calls > 0) {
      state += "; " + std::to_string(shard.stalled_calls->load()) +
               " service call(s) not answered in time, still pending";
    }
    char counted[256];
    std::snprintf(counted, sizeof counted,
                  "; %ld answers, %ld missed, %ld late, %ld for stamps no descriptor had, %ld "
                  "with impossible distances",
                  static_cast<long>(counts.answered), static_cast<long>(counts.missed),
                  static_cast<long>(counts.late), static_cast<long>(counts.unheard),
                  static_cast<long>(shard.invalid_answers));
    add("shard " + shard.name,
        state + counted + (shard.invalid.empty() ? "" : " (last: " + shard.invalid + ")"));
  }
  return status;
}

}  // namespace bsf_vpr
