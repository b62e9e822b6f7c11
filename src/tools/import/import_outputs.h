// What bsf_import makes of a traversal: a reference set (the frames that describe its
// places) and a query bag (every frame, with its pose and ground truth).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/image/image_describer.h"
#include "src/tools/common/query_bag.h"
#include "src/tools/import/import_places.h"
#include "src/tools/import/import_traversal.h"

namespace bsf_vpr {
namespace tools {

// Describes frames: an image (LoadFrameImage, resized to `resize` unless empty) through
// `describer`, or a row of the traversal's descriptor .npy. `describer` may be null when
// every traversal is a .npy; it must outlive this object.
class FrameDescriber {
 public:
  FrameDescriber(const ImageDescriber* describer, cv::Size resize)
      : describer_(describer), resize_(resize) {}
  Eigen::VectorXf Describe(const Traversal& t, const Frame& f) const;
  // The describer's type for image traversals, "" for a .npy.
  std::string DescriptorType(const Traversal& t) const;
  cv::Size resize() const { return resize_; }

 private:
  const ImageDescriber* describer_;
  cv::Size resize_;
};

// The reference set of `t`: row k describes place a.place_ids[k] with frame a.frames[k],
// and (with_poses) has that frame's pose, where the place was seen: a.place_poses[k],
// within the association radius of the place's pose in the shared index. An image
// traversal's set names its images: t.image_folder (absolute) and frame a.frames[k]'s file
// for row k. Throws std::runtime_error naming an unreadable image.
ReferenceSet MakeImportedSet(const Traversal& t, const PlaceAssignment& a,
                             const FrameDescriber& describer, bool with_poses,
                             const std::string& condition, const std::string& distance);

// The correct places of a query frame: by position (places within a radius of its pose)
// or, for frame-aligned traversals, places k-tolerance..k+tolerance of frame k.
struct QueryTruth {
  const PlacesWithinRadius* by_position = nullptr;
  int tolerance = 0;   // frame-aligned
  int num_places = 0;  // frame-aligned: the size of the place index
};

// Writes every frame of `t` to `bag` in order: the image (or its descriptor, with
// `as_descriptors`), its ground truth and, for traversals with poses, its pose. Stamps are
// the frames' own, or 1000 s + k / rate_hz when rate_hz > 0. Returns the number of queries.
int WriteQueries(const Traversal& t, const FrameDescriber& describer, bool as_descriptors,
                 const QueryTruth& truth, double rate_hz, QueryBagWriter* bag);

}  // namespace tools
}  // namespace bsf_vpr
