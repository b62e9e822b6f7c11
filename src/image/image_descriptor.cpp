#include "bsf_vpr/image/image_descriptor.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "bsf_vpr/image/image_describer.h"

namespace bsf_vpr {

void PatchNormOptions::Validate() const {
  PatchNormOptionsTable().CheckValues(*this);  // each field's bounds
  if (patch_size_px > std::min(width_px, height_px)) {
    throw std::invalid_argument(
        "patch_size_px must lie in 1..min(patch_width_px, patch_height_px) = " +
        std::to_string(std::min(width_px, height_px)) + ", got " + std::to_string(patch_size_px));
  }
}

const OptionTable<PatchNormOptions>& PatchNormOptionsTable() {
  static const OptionTable<PatchNormOptions> kTable =
      OptionTable<PatchNormOptions>()
          .Add(
              "patch_width_px", [](auto& o) -> auto& { return o.width_px; },
              "patchnorm: width the image is resized to", "px", AtLeast(1))
          .Add(
              "patch_height_px", [](auto& o) -> auto& { return o.height_px; },
              "patchnorm: height the image is resized to", "px", AtLeast(1))
          .Add(
              "patch_size_px", [](auto& o) -> auto& { return o.patch_size_px; },
              "patchnorm: side of the patches normalised to zero mean and unit variance", "px",
              AtLeast(1));
  return kTable;
}

std::string PatchNormOptions::DescriptorType() const {
  return "patchnorm_" + std::to_string(width_px) + "x" + std::to_string(height_px) + "_p" +
         std::to_string(patch_size_px);
}

namespace {

// The conversion code from `channels` (1, 3 or 4) to `target` (1 or 3); -1 for none.
int ConversionCode(const cv::Mat& image, int target) {
  if (image.empty()) throw std::invalid_argument("cannot describe an empty image");
  if (image.depth() != CV_8U) {
    throw std::invalid_argument("expected an 8-bit image, got OpenCV depth " +
                                std::to_string(image.depth()));
  }
  switch (image.channels()) {
    case 1:
      return target == 1 ? -1 : cv::COLOR_GRAY2BGR;
    case 3:
      return target == 3 ? -1 : cv::COLOR_BGR2GRAY;
    case 4:
      return target == 1 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGRA2BGR;
    default:
      throw std::invalid_argument("expected 1, 3 or 4 channels, got " +
                                  std::to_string(image.channels()));
  }
}

cv::Mat Convert(const cv::Mat& image, int target) {
  const int code = ConversionCode(image, target);
  if (code < 0) return image;
  cv::Mat out;
  cv::cvtColor(image, out, code);
  return out;
}

}  // namespace

cv::Mat ToGrayscale8(const cv::Mat& image) { return Convert(image, 1); }

cv::Mat ToBgr8(const cv::Mat& image) { return Convert(image, 3); }

Eigen::VectorXf DescribePatchNormalized(const cv::Mat& image, const PatchNormOptions& options) {
  options.Validate();
  const cv::Mat gray = ToGrayscale8(image);
  cv::Mat small;
  const cv::Size size(options.width_px, options.height_px);
  if (gray.size() == size) {
    small = gray;
  } else {
    cv::resize(gray, small, size, 0, 0, cv::INTER_AREA);
  }
  cv::Mat f;
  small.convertTo(f, CV_32F);
  Eigen::VectorXf out(options.dimension());
  const int p = options.patch_size_px;
  for (int y0 = 0; y0 < options.height_px; y0 += p) {
    for (int x0 = 0; x0 < options.width_px; x0 += p) {
      const int y1 = std::min(y0 + p, options.height_px);
      const int x1 = std::min(x0 + p, options.width_px);
      double sum = 0, sq = 0;
      for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) sum += f.at<float>(y, x);
      }
      const double n = static_cast<double>((y1 - y0) * (x1 - x0));
      const double mean = sum / n;
      for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) sq += (f.at<float>(y, x) - mean) * (f.at<float>(y, x) - mean);
      }
      const double sd = std::sqrt(sq / n);
      for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
          out(y * options.width_px + x) =
              sd > 0 ? static_cast<float>((f.at<float>(y, x) - mean) / sd) : 0.0f;
        }
      }
    }
  }
  return out;
}

RowMatrixXf DescribeImageFolder(const std::string& folder, const PatchNormOptions& options) {
  ImageDescriberOptions o;
  o.patch_norm = options;
  return DescribeImageFolder(folder, *MakeImageDescriber(o));
}

}  // namespace bsf_vpr
