#include "src/ros/map/map_params.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>
#include <stdexcept>

namespace bsf_vpr {
namespace {

std::string Member(XmlRpc::XmlRpcValue& entry, const char* key, size_t index, bool required) {
  if (!entry.hasMember(key)) {
    if (required) {
      throw std::invalid_argument("reference_sets[" + std::to_string(index) + "] has no '" + key +
                                  "'");
    }
    return "";
  }
  if (entry[key].getType() != XmlRpc::XmlRpcValue::TypeString) {
    throw std::invalid_argument("reference_sets[" + std::to_string(index) + "]." + key +
                                " must be a string");
  }
  return static_cast<std::string>(entry[key]);
}

}  // namespace

std::vector<ReferenceSetEntry> LoadReferenceSetEntries(RosParamSource& source) {
  std::vector<ReferenceSetEntry> out;
  std::optional<XmlRpc::XmlRpcValue> raw = source.GetRaw("reference_sets");
  if (!raw) return out;
  XmlRpc::XmlRpcValue& list = *raw;
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    throw std::invalid_argument("reference_sets must be a list of {name, path, condition}");
  }
  for (int i = 0; i < list.size(); ++i) {
    XmlRpc::XmlRpcValue& e = list[i];
    const size_t idx = static_cast<size_t>(i);
    if (e.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      throw std::invalid_argument("reference_sets[" + std::to_string(idx) + "] is not a mapping");
    }
    for (auto it = e.begin(); it != e.end(); ++it) {
      if (it->first != "name" && it->first != "path" && it->first != "condition") {
        throw std::invalid_argument("reference_sets[" + std::to_string(idx) +
                                    "] has unknown key '" + it->first +
                                    "' (expected name, path, condition)");
      }
    }
    out.push_back({Member(e, "name", idx, false), Member(e, "path", idx, true),
                   Member(e, "condition", idx, false)});
  }
  return out;
}

std::vector<std::string> LoadShardNames(RosParamSource& source) {
  std::vector<std::string> out;
  std::optional<XmlRpc::XmlRpcValue> raw = source.GetRaw("shards");
  if (!raw) return out;
  XmlRpc::XmlRpcValue& list = *raw;
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    throw std::invalid_argument("shards must be a list of shard names, e.g. [shard_0, shard_1]");
  }
  for (int i = 0; i < list.size(); ++i) {
    if (list[i].getType() != XmlRpc::XmlRpcValue::TypeString ||
        static_cast<std::string>(list[i]).empty()) {
      throw std::invalid_argument("shards[" + std::to_string(i) + "] is not a shard name");
    }
    const std::string name = static_cast<std::string>(list[i]);
    if (std::find(out.begin(), out.end(), name) != out.end()) {
      throw std::invalid_argument("shards names '" + name + "' twice");
    }
    out.push_back(name);
  }
  return out;
}

const OptionTable<MapParams>& MapParamsTable() {
  static const OptionTable<MapParams> kTable =
      OptionTable<MapParams>()
          .AddExternal("reference_sets",
                       "reference sets loaded at start: a list of {name, path, condition}. "
                       "path is a descriptor .npy (then name is required) or a reference-set "
                       ".yaml; relative paths are relative to data_directory. All sets share "
                       "one descriptor dimension.",
                       "[]")
          .Add(
              "data_directory", [](auto& p) -> auto& { return p.data_directory; },
              "folder below which the load_reference_set, start_recording and "
              "stop_recording services read and write files (created at start); paths that "
              "escape it are refused. \"\" turns those services off (bsf_vpr.launch sets "
              "it from its data_directory argument)")
          .AddChoice(
              "distance", [](auto& p) -> auto& { return p.distance; },
              "distance between descriptors (not squared); \"\": the distance the sets "
              "loaded at start declare (YAML distance:), or the first set loaded into "
              "an empty node; else euclidean",
              DistanceMetricNames())
          .AddChoice(
              "storage", [](auto& p) -> auto& { return p.storage; },
              "precision every reference set is held at: float16 halves and int8 (one "
              "scale per set) quarters the bytes and the time per query",
              StoragePrecisionNames())
          .Add(
              "memory_map", [](auto& p) -> auto& { return p.memory_map; },
              "map each reference set's descriptor .npy into memory instead of reading it, "
              "where the file holds the rows at storage (bsf_store_set writes a set so; "
              "other files are read as before): a set then costs its norms and, with "
              "first_stage pca, its codes, not its bytes, and the page cache keeps what is "
              "read of it (docs/performance.md, maps larger than memory)")
          .Add(
              "place_pose_tolerance_m", [](auto& p) -> auto& { return p.place_pose_tolerance_m; },
              "a reference set (loaded or recorded) that puts a place farther than this from "
              "where the loaded sets have it is refused: its place ids belong to another map",
              "m", Above(0));
  return kTable;
}

const OptionTable<ShardingParams>& ShardingParamsTable() {
  static const OptionTable<ShardingParams> kTable =
      OptionTable<ShardingParams>()
          .AddExternal("shards",
                       "sharded map (docs/sharding.md): the fusion shards whose sets this node "
                       "fuses, a list of their names (resolved in this node's namespace, e.g. "
                       "[shard_0, shard_1]); the map's set order is theirs, shard by shard. "
                       "Empty: this node holds its own sets (reference_sets), the usual case",
                       "[]")
          .Add(
              "shard_timeout", [](auto& p) -> auto& { return p.shard_timeout; },
              "sharded map: how long a query waits for the shards that have not answered "
              "after the first one did; then it is decided without their sets "
              "(Belief.missing_sets); a shard that was slow is waited for again, so its first "
              "answer within it takes the shard back",
              "s", Above(0))
          .Add(
              "shard_call_timeout", [](auto& p) -> auto& { return p.shard_call_timeout; },
              "sharded map: how long a call to a shard's service (query_place's "
              "get_distances, a routed unload) waits beyond shard_timeout; a shard that has "
              "not answered is reported and not called again until that call returns",
              "s", Above(0))
          .Add(
              "shard_load_timeout", [](auto& p) -> auto& { return p.shard_load_timeout; },
              "sharded map: how long a routed load_reference_set waits for the shard (reading "
              "a large set takes a while); a load that outlasts it may still complete: the map "
              "takes the set when the shard publishes it",
              "s", Above(0));
  return kTable;
}

}  // namespace bsf_vpr
