#include "src/tools/import/import_outputs.h"

#include <filesystem>
#include <stdexcept>

#include "bsf_vpr/evaluation/evaluation.h"

namespace bsf_vpr {
namespace tools {
namespace {

constexpr double kStartTimeS = 1000.0;  // with rate_hz: a fixed, non-zero first stamp

}  // namespace

Eigen::VectorXf FrameDescriber::Describe(const Traversal& t, const Frame& f) const {
  if (f.row >= 0) return t.descriptors.row(f.row).transpose();
  if (describer_ == nullptr) throw std::logic_error("FrameDescriber: no image describer");
  return describer_->Describe(LoadFrameImage(t, f, resize_));
}

std::string FrameDescriber::DescriptorType(const Traversal& t) const {
  return t.descriptors.size() > 0 || describer_ == nullptr ? "" : describer_->descriptor_type();
}

ReferenceSet MakeImportedSet(const Traversal& t, const PlaceAssignment& a,
                             const FrameDescriber& describer, bool with_poses,
                             const std::string& condition, const std::string& distance) {
  ReferenceSet set;
  set.name = t.name;
  set.condition = condition;
  set.distance = distance;
  set.descriptor_type = describer.DescriptorType(t);
  set.place_ids = a.place_ids;
  if (with_poses) set.poses = a.place_poses;
  if (!t.image_folder.empty()) {
    set.images = std::filesystem::absolute(t.image_folder).lexically_normal().string();
  }
  for (size_t k = 0; k < a.frames.size(); ++k) {
    const Frame& frame = t.frames.at(static_cast<size_t>(a.frames[k]));
    const Eigen::VectorXf d = describer.Describe(t, frame);
    if (k == 0) set.descriptors.resize(static_cast<Eigen::Index>(a.frames.size()), d.size());
    set.descriptors.row(static_cast<Eigen::Index>(k)) = d.transpose();
    if (!t.image_folder.empty()) {
      set.image_files.push_back(
          std::filesystem::path(frame.image).lexically_relative(t.image_folder).string());
    }
  }
  return set;
}

int WriteQueries(const Traversal& t, const FrameDescriber& describer, bool as_descriptors,
                 const QueryTruth& truth, double rate_hz, QueryBagWriter* bag) {
  const int n = static_cast<int>(t.frames.size());
  const GroundTruth aligned =
      truth.by_position == nullptr
          ? GroundTruth::FromFrameTolerance(n, truth.num_places, truth.tolerance)
          : GroundTruth();
  const bool with_poses = t.pose_coordinates != PoseCoordinates::kNone;
  const std::string type = describer.DescriptorType(t);
  for (int k = 0; k < n; ++k) {
    const Frame& f = t.frames[static_cast<size_t>(k)];
    ros::Time stamp;
    if (rate_hz > 0) {
      stamp = ros::Time(kStartTimeS + k / rate_hz);
    } else {
      stamp.fromNSec(static_cast<uint64_t>(f.stamp_ns));
    }
    if (as_descriptors) {
      const Eigen::VectorXf d = describer.Describe(t, f);
      bag->WriteDescriptor(stamp, d.data(), static_cast<int>(d.size()), type);
    } else {
      bag->WriteImage(stamp, LoadFrameImage(t, f, describer.resize()));
    }
    bag->WriteGroundTruth(stamp, k,
                          truth.by_position != nullptr ? truth.by_position->Around(f.pose)
                                                       : aligned.CorrectPlaces(k));
    if (with_poses) bag->WritePose(stamp, f.pose);
  }
  return n;
}

}  // namespace tools
}  // namespace bsf_vpr
