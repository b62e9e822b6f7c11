// Records a new reference set from descriptors that stream in (a robot adding today's
// traversal to its map): the k-th descriptor added becomes place k.
//
// Not thread-safe: callers serialise access.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

class ReferenceRecorder {
 public:
  // Starts a recording. `dimension` 0 accepts the dimension of the first descriptor.
  // Throws std::invalid_argument if a recording is running or the name is empty.
  void Start(const std::string& name, const std::string& condition, int dimension);
  bool recording() const { return recording_; }
  const std::string& name() const { return name_; }
  int count() const { return static_cast<int>(rows_.size()); }

  // Adds one descriptor (and its pose, if known). Throws std::invalid_argument if no
  // recording runs, or for a wrong dimension or a non-finite value (nothing is added).
  void Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
           const std::optional<PlacePose>& pose = std::nullopt);

  // Ends the recording and returns the set. Poses are kept only if every descriptor had one.
  // Throws std::invalid_argument if nothing was recorded (the recording stays open).
  ReferenceSet Finish(const std::string& descriptor_type = "");
  // The set recorded so far, the recording left running (so that a save that fails loses
  // nothing: Discard once it succeeded). Throws std::invalid_argument like Finish.
  ReferenceSet Build(const std::string& descriptor_type = "") const;
  // Ends the recording and drops what was recorded.
  void Discard();

 private:
  bool recording_ = false;
  std::string name_, condition_;
  int dimension_ = 0;
  std::vector<Eigen::VectorXf> rows_;
  std::vector<std::optional<PlacePose>> poses_;
};

}  // namespace bsf_vpr
