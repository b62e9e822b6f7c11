// What the fusion node asks of the map it decides on: the place layout, each query's
// distances to the sets, and the services that change the sets. Two implementations:
// LocalMap (local_map.h) holds the sets in this process; ShardedMap (src/ros/map) fuses the
// distances that fusion shards compute for the sets they hold (docs/sharding.md). The node
// is handed one and is written against this interface alone, as cartographer_ros's Node is
// against MapBuilderInterface.
//
// Plain C++: requests, answers and status are the types below, and the ROS layer converts
// its messages to and from them (src/ros/common/conversions.h), so that a map, and a node
// over a fake one, is built and tested without ROS.
//
// Every member is thread-safe. Those that may block for long (Load, Unload, Ask: files,
// shards) are called without the node's own lock; the others (layout, metric, Hear, Add,
// the diagnostics) with it, so a map never takes the node's lock from them.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/query_distances.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/map/map_calibrator.h"

namespace bsf_vpr {

// The header of the descriptor a query is for, as std_msgs/Header carries it: the stamp in
// whole seconds and nanoseconds, so that it comes back to ROS exactly.
struct QueryHeader {
  uint32_t seq = 0;
  uint32_t sec = 0, nsec = 0;
  std::string frame_id;

  int64_t stamp_ns() const { return int64_t{sec} * 1000000000 + nsec; }
  double stamp_s() const { return sec + 1e-9 * nsec; }
  bool stamp_is_zero() const { return sec == 0 && nsec == 0; }
};

// A descriptor the map is asked about: its header and type, and a view on its values (valid
// for the call that hands it over; a map that keeps it copies it).
struct QueryDescriptor {
  QueryHeader header;
  std::string type;  // may be empty (not declared)
  const float* values = nullptr;
  Eigen::Index size = 0;

  Eigen::Map<const Eigen::VectorXf> view() const { return {values, size}; }
};

// load_reference_set's request: a file below the data directory, the name and condition that
// override the file's, and (a sharded map) the shard to load it on ("": the least loaded).
struct LoadRequest {
  std::string path, name, condition, shard;
};

// One set as list_reference_sets describes it: its layout (name, condition, places...) and
// what holding it costs.
struct SetSummary {
  SetLayout layout;
  uint64_t memory_bytes = 0;
  std::string storage;  // float32, float16 or int8, with " (memory-mapped)" when it is
  std::string shard;    // the shard holding it ("" in a map of this process)
};
struct SetList {
  std::vector<SetSummary> sets;
  int num_places = 0;       // of the shared place index
  std::string calibration;  // what the map knows of itself (MapCalibrator::status)
};

// A map's diagnostics: key and value, in order (the node adds them to its status).
using StatusValues = std::vector<std::pair<std::string, std::string>>;

// A layout as a map made it. It never changes once made: a change of sets makes a new one,
// numbered after the last, so that a query decided on an older one is told apart.
struct NumberedLayout : PlaceLayout {
  NumberedLayout(PlaceLayout places, uint64_t generation)
      : PlaceLayout(std::move(places)), generation(generation) {}
  uint64_t generation;
};

class MapBackend {
 public:
  using Layout = std::shared_ptr<const NumberedLayout>;

  // One query's distances, and the layout they are for.
  struct Query {
    QueryHeader header;  // the descriptor's
    Layout layout;
    QueryDistances distances;                 // set by set of *layout
    std::vector<std::string> missing_shards;  // shards whose sets are absent from it
    double seconds = 0;                       // time spent on the distances (slowest shard)
    // The map's own acceptance rule (SetCalibration), as its latest calibration made it;
    // nullopt: none (none asked for, none yet, one traversal, or a map that cannot).
    std::optional<AcceptanceRule> acceptance_rule;
  };
  // A map that learns of queries and changes by itself (the sharded map: its shards hear
  // the descriptors and publish their sets) hands them on here, from its own threads, one
  // call at a time and in order: each query once, in stamp order; `reject` says why a query
  // cannot be decided; `layout` gives each new layout as it is made.
  struct Callbacks {
    std::function<void(Query& query)> query;
    std::function<void(const std::string& why)> reject;
    std::function<void(Layout layout)> layout;
  };

  virtual ~MapBackend() = default;

  // From now on the map may call `callbacks` (a map that learns of nothing by itself never
  // does). Called once, when everything the callbacks use exists.
  virtual void Start(Callbacks callbacks) = 0;

  // The layout now (never null: empty before any set).
  virtual Layout layout() const = 0;
  // The distance the sets are compared with.
  virtual DistanceMetric metric() const = 0;

  // A descriptor the node heard. A map holding the sets returns its query now; a sharded
  // map returns nullopt (its query comes through Callbacks::query once the shards
  // answered). Throws std::invalid_argument naming what is wrong with the descriptor.
  virtual std::optional<Query> Hear(const QueryDescriptor& descriptor) = 0;
  // The query of one descriptor now, whoever holds the sets (query_place). Throws
  // std::invalid_argument when it cannot be answered.
  virtual Query Ask(const QueryDescriptor& descriptor) = 0;

  // load_reference_set and unload_reference_set: the message of success, or throws
  // std::invalid_argument with the refusal (the sets unchanged). `check` (may be empty)
  // sees the name of a set read in this process before it joins, and throws to refuse it;
  // it is called with no lock of the map held.
  using SetCheck = std::function<void(const std::string& name)>;
  virtual std::string Load(const LoadRequest& request, const SetCheck& check) = 0;
  virtual std::string Unload(const std::string& name) = 0;
  // A set recorded by the node, added as it was saved (from `where`). Throws as Load.
  virtual std::string Add(ReferenceSet set, const std::string& where) = 0;
  // Why this map cannot take a set the node records ("" if it can).
  virtual std::string CannotRecord() const = 0;
  virtual SetList List() const = 0;

  // The joint representation of the sets the method needs (Method::JointNeeded; nullopt:
  // none), built with `options` in the background after every change of sets, the previous
  // one answering meanwhile where it still fits the places; each query then carries its
  // distances to it (QueryDistances::joint). A map that cannot build one (a sharded map)
  // says so in Problem() when one is asked for, and the method goes on without it.
  virtual void SetJoint(std::optional<JointKind> kind, const JointOptions& options) = 0;
  // Blocks until no joint representation is being built (start-up; a sharded map's shards
  // build theirs on their own: it returns at once).
  virtual void WaitForJoint() const = 0;

  // What the map calibrates itself for (map_calibrator.h; nullopt: nothing, the threshold
  // alone), in the background after every change of sets, the previous calibration
  // answering meanwhile; each query then carries its rule (Query::acceptance_rule). A map
  // that cannot (a sharded map: its combiner holds no descriptors) says so in List().
  virtual void SetCalibration(std::optional<CalibrationRequest> request) = 0;

  // Why the map works short of what it was asked ("" if it does not): shards missing, a
  // first stage that fell back to exact search. A warning in the node's diagnostics.
  virtual std::string Problem() const = 0;
  virtual StatusValues Diagnose() const = 0;
};

// How a map of this process reports what it does (a set loaded, a first stage built or
// failed): the ROS layer logs it with ROS_INFO / ROS_WARN / ROS_ERROR.
enum class LogLevel { kInfo, kWarn, kError };
using MapLog = std::function<void(LogLevel level, const std::string& message)>;

}  // namespace bsf_vpr
