// A map whose reference sets live in this process: the fusion node's map when it holds its
// own sets, and the set-holding part of a fusion shard. Free of ROS. It reads the configured sets
// and those load_reference_set names (below the data directory), stores them (ReferenceMap, at the
// configured storage precision), computes a query's distances to each of them (DistanceStage:
// exact, or the pca first stage) and keeps the sets' layout.
//
// Thread-safe: one lock guards the sets; a load reads its file without it, so recognition
// goes on meanwhile. Each query comes with the layout it was computed for.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/joint_builder.h"
#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/map/map_backend.h"

namespace bsf_vpr {

struct LocalMapOptions {
  // The distance, or nullopt: the one the first sets declare (euclidean if none does).
  std::optional<DistanceMetric> metric;
  StoragePrecision storage = StoragePrecision::kFloat32;
  double place_pose_tolerance_m = 25;
  FirstStageOptions first_stage;
  bool fingerprints = false;  // keep each set's SetFingerprint (a shard's answers carry them)
  MapLog log;                 // what the map reports (may be empty: nothing reported)
};

// A configured set: its file (already resolved: absolute or relative to the working
// directory), and the name and condition that override the file's ("": the file's).
struct ConfiguredSet {
  std::string path, name, condition;
};

// A shard's answer for one descriptor (LocalMap::Answer): the distances to every set held,
// with the sets' names and fingerprints, and the joint representation's if one fits; or why
// the descriptor was refused.
struct ShardAnswer {
  std::vector<std::string> set_names;
  std::vector<uint64_t> fingerprints;
  std::vector<RowMatrixXf> distances;  // 1 x N_u each
  std::optional<JointKind> joint_kind;
  uint64_t joint_build = 0;
  std::vector<std::string> joint_sets;
  RowMatrixXf joint_distances;
  std::string error;  // "" unless refused
};

class LocalMap : public MapBackend {
 public:
  // `data_dir` (may be null: load_reference_set refused) outlives the map. `shard` names
  // the shard holding it in messages ("": a node's own map).
  LocalMap(LocalMapOptions options, const DataDirectory* data_dir, std::string shard = "");

  // The configured sets (start-up), their paths resolved by the caller (the ROS layer
  // resolves package://PACKAGE/PATH). Throws std::exception naming the file or the sets'
  // disagreeing distances; a node that cannot start then discards the map.
  void LoadConfigured(const std::vector<ConfiguredSet>& sets);

  void Start(Callbacks) override {}  // it learns of nothing by itself
  Layout layout() const override;
  DistanceMetric metric() const override;
  std::optional<Query> Hear(const QueryDescriptor& descriptor) override { return Ask(descriptor); }
  Query Ask(const QueryDescriptor& descriptor) override;
  std::string Load(const LoadRequest& request, const SetCheck& check) override;
  std::string Unload(const std::string& name) override;
  std::string Add(ReferenceSet set, const std::string& where) override;
  std::string CannotRecord() const override { return ""; }
  SetList List() const override;
  // Why descriptors of `type` should not meet the sets (TypeMismatch).
  std::string DescriptorTypeMismatch(const std::string& type) const;
  void SetJoint(std::optional<JointKind> kind, const JointOptions& options) override;
  void WaitForJoint() const override { joint_builder_.Wait(); }
  std::string Problem() const override;
  StatusValues Diagnose() const override;

  // A fusion shard's answer for `descriptor` (its distances to every set held, with the
  // sets' fingerprints: needs options.fingerprints), or the refusal in `error`.
  ShardAnswer Answer(const QueryDescriptor& descriptor);
  // Calls `visit` with each set held and its fingerprint (0 without options.fingerprints),
  // in the map's order, under the map's lock (a shard describing its sets to its combiner).
  void ForEachSet(
      const std::function<void(const StoredReferenceSet& set, uint64_t fingerprint)>& visit) const;
  int num_sets() const;

 private:
  // Adds `set` (read from `where`) under mutex_: adopts its distance when none is
  // configured and nothing is loaded yet, refuses a set meant for another distance.
  std::string AddLocked(ReferenceSet set, const std::string& where) REQUIRES(mutex_);
  // The descriptor as a 1 x D query, checked against the sets. Throws std::invalid_argument.
  RowMatrixXf QueryRow(const QueryDescriptor& descriptor) const REQUIRES(mutex_);
  // After every change of sets, with mutex_ held: a new layout, and the first stage's index
  // for the new sets (first_stage pca), logged; a failed build falls back to exact search.
  // The joint representation is asked of the builder (RequestJoint).
  void Changed() REQUIRES(mutex_);
  // With mutex_ held: asks for the joint representation of the sets now (if one is wanted
  // and they can make one), and drops the current one if it no longer fits the places.
  void RequestJoint() REQUIRES(mutex_);
  // The builder's result (its thread): taken if it is for the sets now.
  void JointBuilt(JointBuilder::Result result) EXCLUDES(mutex_);
  void Log(LogLevel level, const std::string& message) const;

  const LocalMapOptions options_;
  const DataDirectory* const data_dir_;
  const std::string shard_;
  mutable Mutex mutex_;
  ReferenceMap map_ GUARDED_BY(mutex_);
  DistanceStage stage_ GUARDED_BY(mutex_);
  DistanceMetric metric_ GUARDED_BY(mutex_);
  std::vector<uint64_t> fingerprints_ GUARDED_BY(mutex_);  // SetFingerprint of each set of map_
  Layout layout_ GUARDED_BY(mutex_);
  uint64_t generations_ GUARDED_BY(mutex_) = 0;  // layouts made
  // Why the pca first stage fell back to exact, if it did.
  std::string first_stage_error_ GUARDED_BY(mutex_);
  // The joint representation: the kind wanted, the one answering (null: none), the build
  // it came from (numbered), and what the last build said.
  std::optional<JointKind> joint_kind_ GUARDED_BY(mutex_);
  JointOptions joint_options_ GUARDED_BY(mutex_);
  std::shared_ptr<const JointRepresentation> joint_ GUARDED_BY(mutex_);
  uint64_t joint_build_ GUARDED_BY(mutex_) = 0;
  uint64_t joint_builds_ GUARDED_BY(mutex_) = 0;
  std::string joint_status_ GUARDED_BY(mutex_) = "none asked for";
  // Last: destroyed first, so that no build calls back into a map being destroyed.
  JointBuilder joint_builder_{[this](JointBuilder::Result r) { JointBuilt(std::move(r)); }};
};

}  // namespace bsf_vpr
