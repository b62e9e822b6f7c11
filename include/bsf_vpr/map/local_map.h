// A map whose reference sets live in this process: the fusion node's map when it holds its
// own sets, and the set-holding part of a fusion shard. Free of ROS. It reads the configured sets
// and those load_reference_set names (below the data directory), stores them (ReferenceSets, at the
// configured storage precision), computes a query's distances to each of them (DistanceStage:
// exact, or the pca first stage) and keeps the sets' layout.
//
// Thread-safe: one lock guards the sets; a load reads its file without it, so recognition
// goes on meanwhile. Each query comes with the layout it was computed for.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/joint_builder.h"
#include "bsf_vpr/core/latest_job.h"
#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/core/query_distances.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/map/map_backend.h"

namespace bsf_vpr {

struct LocalMapOptions {
  // The distance, or nullopt: the one the first sets declare (euclidean if none does).
  std::optional<DistanceMetric> metric;
  StoragePrecision storage = StoragePrecision::kFloat32;
  double place_pose_tolerance_m = kDefaultPlacePoseToleranceM;
  FirstStageOptions first_stage;
  // Map each set's descriptor .npy instead of reading it, where the file holds the rows at
  // `storage` (ReadSetOptions::memory_map; bsf_store_set writes them so): a set then costs its
  // norms and, with first_stage pca, its codes, not its bytes.
  bool memory_map = false;
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
  std::string error;   // "" unless refused
  double seconds = 0;  // the time the shard spent on the descriptor
  // Received with set names, fingerprints and counts that do not hold together (a corrupted
  // message): its sets' distances are not used, its joint distances may be.
  bool malformed = false;
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
  void SetCalibration(std::optional<CalibrationRequest> request) override;
  // Blocks until no calibration runs or waits (tests, benchmarks).
  void WaitForCalibration() const { calibrator_.Wait(); }
  // The rule of the map's latest calibration (what each query carries; nullopt: none).
  std::optional<AcceptanceRule> acceptance_rule() const { return calibrator_.rule(); }
  // Blocks until no build of the first stage's index runs or waits (tests, benchmarks).
  void WaitForIndex() const { index_job_.Wait(); }
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
  // Calls `read` with the sets, under the map's lock (a benchmark's baselines read the rows):
  // `read` must not call into the map (the lock is not recursive).
  void ReadSets(const std::function<void(const ReferenceSets& sets)>& read) const;
  // The first stage's index answering now (first_stage pca; null: exact, or none built yet).
  std::shared_ptr<const ApproximateIndex> index() const;

 private:
  // Adds `set` (read from `where`, encoded by ReferenceSets::Store without the lock) under
  // mutex_: adopts its distance when none is configured and nothing is loaded yet, refuses
  // a set meant for another distance.
  std::string AddLocked(StoredReferenceSet set, const std::string& where) REQUIRES(mutex_);
  // The descriptor as a 1 x D query, checked against the sets. Throws std::invalid_argument.
  RowMatrixXf QueryRow(const QueryDescriptor& descriptor) const REQUIRES(mutex_);
  // After every change of sets, with mutex_ held: a new layout; the first stage's index
  // (first_stage pca) and the joint representation are asked of their builders
  // (RequestIndex, RequestJoint).
  void Changed() REQUIRES(mutex_);
  // The distances of `row` to the sets: exact, or through the first stage's index, where
  // a set it holds no codes of yet is absent (its codes are being built).
  QueryDistances DistancesOf(const RowMatrixXf& row) REQUIRES(mutex_);
  // The query's distances and, if the map has one for these places, its joint distances;
  // the sets whose rows changed while they were read (a mapped file rewritten in place) are
  // absent, and then so is the joint, and *changed is set.
  QueryDistances ReadDistances(const RowMatrixXf& row, bool* changed) REQUIRES(mutex_);
  // Unloads the sets whose rows changed under the map (StoredReferenceSet::RowsChanged: a
  // mapped file rewritten or truncated in place), naming them and the file in an error and in
  // Problem(); a joint representation they are part of goes with them.
  void DropChangedSets() REQUIRES(mutex_);
  // Asks for the first stage's index of the sets now, on index_job_'s thread: the current
  // index extended by the new sets' codes (those it holds are kept), or a new basis for all
  // when there is none or the basis fits a new set poorly. The current index answers for
  // its sets meanwhile; the new one takes over between two queries (IndexBuilt).
  void RequestIndex() REQUIRES(mutex_);
  struct IndexResult {
    uint64_t generation = 0;                        // of the layout it was asked for
    std::shared_ptr<const ApproximateIndex> index;  // null when the build failed
    std::string error;
    std::string how;  // "new basis" or "2 sets kept, 1 projected"
    double seconds = 0;
  };
  void IndexBuilt(IndexResult result) EXCLUDES(mutex_);
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
  ReferenceSets sets_ GUARDED_BY(mutex_);
  DistanceStage stage_ GUARDED_BY(mutex_);
  DistanceMetric metric_ GUARDED_BY(mutex_);
  std::vector<uint64_t> fingerprints_ GUARDED_BY(mutex_);  // SetFingerprint of each set of sets_
  Layout layout_ GUARDED_BY(mutex_);
  uint64_t generations_ GUARDED_BY(mutex_) = 0;  // layouts made
  // Why the pca first stage fell back to exact, if it did.
  std::string first_stage_error_ GUARDED_BY(mutex_);
  // The first stage's index (pca): the one answering (null: none built yet), the layout
  // generation it was asked for, and what the last build said.
  std::shared_ptr<const ApproximateIndex> index_ GUARDED_BY(mutex_);
  uint64_t index_generation_ GUARDED_BY(mutex_) = 0;
  std::string index_status_ GUARDED_BY(mutex_) = "none built yet";
  // The joint representation: the kind wanted, the one answering (null: none), the build
  // it came from (numbered), and what the last build said.
  std::optional<JointKind> joint_kind_ GUARDED_BY(mutex_);
  JointOptions joint_options_ GUARDED_BY(mutex_);
  std::shared_ptr<const JointRepresentation> joint_ GUARDED_BY(mutex_);
  uint64_t joint_build_ GUARDED_BY(mutex_) = 0;
  uint64_t joint_builds_ GUARDED_BY(mutex_) = 0;
  std::string joint_status_ GUARDED_BY(mutex_) = "none asked for";
  // The sets unloaded because their file changed in place, with why, until a set of the
  // same name is loaded again.
  std::map<std::string, std::string> dropped_ GUARDED_BY(mutex_);
  std::string last_dropped_ GUARDED_BY(mutex_);  // Problem() names it
  // Calibrates the sets in the background (its lock is a leaf: taken under mutex_).
  MapCalibrator calibrator_;
  // Last: destroyed first, so that no build calls back into a map being destroyed.
  JointBuilder joint_builder_{[this](JointBuilder::Result r) { JointBuilt(std::move(r)); }};
  LatestJob index_job_;
};

}  // namespace bsf_vpr
