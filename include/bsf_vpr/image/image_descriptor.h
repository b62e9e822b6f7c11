// The patch-normalised downsampled image used by SeqSLAM (Milford & Wyeth, ICRA 2012): the
// image is converted to grayscale, resized to width_px x height_px (area interpolation), and
// each non-overlapping patch_size_px square patch is normalised to zero mean and unit
// variance (a constant patch becomes all zeros). The descriptor is the resulting image,
// row-major, width_px * height_px floats. Compare with Euclidean distance.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

struct PatchNormOptions {
  int width_px = 64;
  int height_px = 32;
  int patch_size_px = 8;  // edge patches are smaller when the size does not divide evenly

  // Throws std::invalid_argument naming the bad field: out of the bounds of
  // PatchNormOptionsTable, or patches larger than the image.
  void Validate() const;
  int dimension() const { return width_px * height_px; }
  std::string DescriptorType() const;  // e.g. "patchnorm_64x32_p8"
};

// patch_width_px, patch_height_px and patch_size_px (part of ImageDescriberOptionsTable,
// image_describer.h).
const OptionTable<PatchNormOptions>& PatchNormOptionsTable();

// Converts an 8-bit image of 1, 3 (BGR) or 4 (BGRA) channels to one channel / to BGR
// (returning the input itself when it already is). Throws std::invalid_argument naming the
// problem for an empty image, another depth or another channel count.
cv::Mat ToGrayscale8(const cv::Mat& image);
cv::Mat ToBgr8(const cv::Mat& image);

// Describes one 8-bit image (1, 3 or 4 channels, BGR order as OpenCV loads it). Throws
// std::invalid_argument for an empty image or an unsupported type.
Eigen::VectorXf DescribePatchNormalized(const cv::Mat& image, const PatchNormOptions& options);

// Describes every image of ListImageFiles(folder) (file_util.h), one row each. Throws
// std::runtime_error naming a file that cannot be decoded.
RowMatrixXf DescribeImageFolder(const std::string& folder, const PatchNormOptions& options);

}  // namespace bsf_vpr
