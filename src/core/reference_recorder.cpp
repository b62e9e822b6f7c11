#include "bsf_vpr/core/reference_recorder.h"

#include <algorithm>
#include <stdexcept>

namespace bsf_vpr {

void ReferenceRecorder::Start(const std::string& name, const std::string& condition,
                              int dimension) {
  if (recording_) {
    throw std::invalid_argument("already recording reference set '" + name_ + "'");
  }
  if (name.empty()) throw std::invalid_argument("a recording needs a non-empty name");
  if (dimension < 0) throw std::invalid_argument("dimension must be >= 0");
  recording_ = true;
  name_ = name;
  condition_ = condition;
  dimension_ = dimension;
  rows_.clear();
  poses_.clear();
}

void ReferenceRecorder::Add(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                            const std::optional<PlacePose>& pose) {
  if (!recording_) throw std::invalid_argument("no recording is running");
  if (descriptor.size() == 0 || (dimension_ != 0 && descriptor.size() != dimension_)) {
    throw std::invalid_argument("recorded descriptor has dimension " +
                                std::to_string(descriptor.size()) + ", expected " +
                                std::to_string(dimension_));
  }
  const std::string problem = DescriptorProblem(descriptor.transpose());
  if (!problem.empty()) throw std::invalid_argument("recorded descriptor " + problem);
  dimension_ = static_cast<int>(descriptor.size());
  rows_.emplace_back(descriptor);
  poses_.push_back(pose);
}

ReferenceSet ReferenceRecorder::Finish(const std::string& descriptor_type) {
  ReferenceSet set = Build(descriptor_type);
  Discard();
  return set;
}

ReferenceSet ReferenceRecorder::Build(const std::string& descriptor_type) const {
  if (!recording_) throw std::invalid_argument("no recording is running");
  if (rows_.empty()) {
    throw std::invalid_argument("recording '" + name_ + "' received no descriptor");
  }
  RowMatrixXf m(static_cast<Eigen::Index>(rows_.size()), dimension_);
  for (size_t k = 0; k < rows_.size(); ++k) m.row(static_cast<Eigen::Index>(k)) = rows_[k];
  ReferenceSet set = MakeReferenceSet(name_, std::move(m), condition_);
  set.descriptor_type = descriptor_type;
  if (std::all_of(poses_.begin(), poses_.end(), [](const auto& p) { return p.has_value(); })) {
    for (const auto& p : poses_) set.poses.push_back(*p);
  }
  return set;
}

void ReferenceRecorder::Discard() {
  recording_ = false;
  rows_.clear();
  poses_.clear();
}

}  // namespace bsf_vpr
