// A map whose reference sets live in this process: the fusion node's map when it holds its
// own sets, and the set-holding part of a fusion shard. It reads the configured sets and
// those load_reference_set names (below the data directory), stores them (ReferenceMap, at
// the configured storage precision), computes a query's distances to each of them
// (DistanceStage: exact, or the pca first stage) and keeps the sets' layout.
//
// Thread-safe: one lock guards the sets; a load reads its file without it, so recognition
// goes on meanwhile. Each query comes with the layout it was computed for.
#pragma once

#include <bsf_vpr/ShardDistances.h>
#include <bsf_vpr/ShardSet.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/joint_builder.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"
#include "src/ros/fusion/fusion_params.h"
#include "src/ros/map/map_backend.h"

namespace bsf_vpr {

struct LocalMapOptions {
  // The distance, or nullopt: the one the first sets declare (euclidean if none does).
  std::optional<DistanceMetric> metric;
  StoragePrecision storage = StoragePrecision::kFloat32;
  double place_pose_tolerance_m = 25;
  FirstStageOptions first_stage;
  bool fingerprints = false;  // keep each set's SetFingerprint (a shard's answers carry them)

  // From a node's map parameters and its first stage.
  static LocalMapOptions From(const MapParams& params, const FirstStageOptions& first_stage);
};

class LocalMap : public MapBackend {
 public:
  // `data_dir` (may be null: load_reference_set refused) outlives the map. `shard` names
  // the shard holding it in messages ("": a node's own map).
  LocalMap(LocalMapOptions options, const DataDirectory* data_dir, std::string shard = "");

  // The configured sets (start-up): paths relative to `base`, absolute, or
  // package://PACKAGE/PATH (set_loading.h). Throws std::exception naming the file or the
  // sets' disagreeing distances; a node that cannot start then discards the map.
  void LoadConfigured(const std::vector<ReferenceSetEntry>& entries, const std::string& base);

  void Start(Callbacks) override {}  // it learns of nothing by itself
  bool NeedsDescriptors() const override { return true; }
  Layout layout() const override;
  DistanceMetric metric() const override;
  std::optional<Query> Hear(const Descriptor& descriptor) override { return Ask(descriptor); }
  Query Ask(const Descriptor& descriptor) override;
  std::string Load(const LoadReferenceSet::Request& request, const SetCheck& check) override;
  std::string Unload(const std::string& name) override;
  std::string Add(ReferenceSet set, const std::string& where) override;
  std::string CannotRecord() const override { return ""; }
  void List(ListReferenceSets::Response* response) const override;
  // Why descriptors of `type` should not meet the sets (TypeMismatch).
  std::string DescriptorTypeMismatch(const std::string& type) const;
  void SetJoint(std::optional<JointKind> kind, const JointOptions& options) override;
  void WaitForJoint() const override { joint_builder_.Wait(); }
  std::string Problem() const override;
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const override;

  // A fusion shard's answer for `descriptor`: its distances to every set held, with the
  // sets' names and fingerprints (SetFingerprint), or the refusal in out->error.
  void ShardAnswer(const Descriptor& descriptor, ShardDistances* out);
  // The sets as a shard describes them to its combiner (ShardInfo::sets).
  std::vector<ShardSet> ShardSets() const;
  int num_sets() const;

 private:
  // Adds `set` (read from `where`) under mutex_: adopts its distance when none is
  // configured and nothing is loaded yet, refuses a set meant for another distance.
  std::string AddLocked(ReferenceSet set, const std::string& where);
  // The descriptor as a 1 x D query, checked against the sets. Throws std::invalid_argument.
  // Caller holds mutex_.
  RowMatrixXf QueryRow(const Descriptor& descriptor) const;
  // After every change of sets, with mutex_ held: a new layout, and the first stage's index
  // for the new sets (first_stage pca), logged; a failed build falls back to exact search.
  // The joint representation is asked of the builder (RequestJoint).
  void Changed();
  // With mutex_ held: asks for the joint representation of the sets now (if one is wanted
  // and they can make one), and drops the current one if it no longer fits the places.
  void RequestJoint();
  // The builder's result (its thread): taken if it is for the sets now.
  void JointBuilt(JointBuilder::Result result);

  const LocalMapOptions options_;
  const DataDirectory* const data_dir_;
  const std::string shard_;
  mutable std::mutex mutex_;
  ReferenceMap map_;
  DistanceStage stage_;
  DistanceMetric metric_;
  std::vector<uint64_t> fingerprints_;  // SetFingerprint of each set of map_
  Layout layout_;
  uint64_t generations_ = 0;       // layouts made
  std::string first_stage_error_;  // why the pca first stage fell back to exact, if it did
  // The joint representation: the kind wanted, the one answering (null: none), the build
  // it came from (numbered), and what the last build said.
  std::optional<JointKind> joint_kind_;
  JointOptions joint_options_;
  std::shared_ptr<const JointRepresentation> joint_;
  uint64_t joint_build_ = 0;
  uint64_t joint_builds_ = 0;
  std::string joint_status_ = "none asked for";
  // Last: destroyed first, so that no build calls back into a map being destroyed.
  JointBuilder joint_builder_{[this](JointBuilder::Result r) { JointBuilt(std::move(r)); }};
};

}  // namespace bsf_vpr
