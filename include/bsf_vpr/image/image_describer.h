// Image descriptors behind one interface, chosen by name: the patch-normalised image
// (image_descriptor.h), HOG (OpenCV), and any ONNX network through OpenCV's dnn module
// (the way users bring NetVLAD, CosPlace or MixVPR exported to ONNX).
#pragma once

#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/types.h"
#include "bsf_vpr/image/image_descriptor.h"

namespace bsf_vpr {

// HOG over the whole (resized) image: cells of cell_px, blocks of 2 x 2 cells moved by one
// cell, `bins` orientation bins (OpenCV's HOGDescriptor).
struct HogOptions {
  int width_px = 64;
  int height_px = 32;
  int cell_px = 8;
  int bins = 9;

  // Throws std::invalid_argument naming the bad field: out of the bounds of HogOptionsTable,
  // or sizes that are not multiples of cell_px of at least 2 cells each way.
  void Validate() const;
  int dimension() const;
};

// hog_width_px, hog_height_px, hog_cell_px and hog_bins (part of ImageDescriberOptionsTable).
const OptionTable<HogOptions>& HogOptionsTable();

// An ONNX network. The image is converted to RGB (or kept BGR), resized to
// input_width_px x input_height_px, scaled to [0, 1], normalised per channel with mean and
// std, and fed as a 1 x 3 x H x W tensor. The output (output_layer, or the network's last
// output when empty) is flattened, optionally projected by a K x D PCA matrix loaded from a
// .npy, and optionally L2-normalised.
struct OnnxOptions {
  std::string model_path;
  int input_width_px = 224;
  int input_height_px = 224;
  std::vector<float> mean = {0.485f, 0.456f, 0.406f};  // per channel, in [0, 1] units
  std::vector<float> std = {0.229f, 0.224f, 0.225f};
  bool rgb = true;           // feed R, G, B (false: B, G, R as OpenCV loads images)
  std::string output_layer;  // empty: the default output
  std::string pca_path;      // optional K x D .npy; empty: no projection
  bool l2_normalize = true;

  // Throws std::invalid_argument naming the bad field: no model, out of the bounds of
  // OnnxOptionsTable, or not 3 values of mean and std.
  void Validate() const;
};

// The onnx_* options (part of ImageDescriberOptionsTable).
const OptionTable<OnnxOptions>& OnnxOptionsTable();

enum class ImageDescriberKind { kPatchNorm, kHog, kOnnx };

// The describers' names (image_descriptor).
const EnumNames<ImageDescriberKind>& ImageDescriberKindNames();
// A name of ImageDescriberKindNames(); throws std::invalid_argument naming the choices otherwise.
ImageDescriberKind ParseImageDescriberKind(const std::string& name);
std::string ToString(ImageDescriberKind kind);

struct ImageDescriberOptions {
  ImageDescriberKind kind = ImageDescriberKind::kPatchNorm;
  PatchNormOptions patch_norm;
  HogOptions hog;
  OnnxOptions onnx;
};

// The options of ImageDescriberOptions: ROS parameters of the ingest nodelet and flags of
// the tools that describe image folders (--image-descriptor hog --hog-cell-px 8).
const OptionTable<ImageDescriberOptions>& ImageDescriberOptionsTable();

// Checks the options of the chosen describer (and the patch-normalised ones, always).
// Throws std::invalid_argument naming the bad option. A missing ONNX model is found later,
// by MakeImageDescriber.
void ValidateImageDescriberOptions(const ImageDescriberOptions& options);

class ImageDescriber {
 public:
  virtual ~ImageDescriber() = default;
  // Describes one 8-bit image (1, 3 or 4 channels, BGR as OpenCV loads it). Thread-safe.
  // Throws std::invalid_argument for an image it cannot take.
  virtual Eigen::VectorXf Describe(const cv::Mat& image) const = 0;
  virtual int dimension() const = 0;
  virtual std::string descriptor_type() const = 0;  // e.g. "hog_64x32_c8_b9"
};

// Why `image` (8-bit, 1, 3 or 4 channels) shows nothing to recognise a place by ("" if it
// shows something), as a covered, black, dazzled or fogged camera gives:
// - every pixel of it is alike ("is uniform"); its descriptor carries no information: the
//   patch-normalised one and HOG are all zeros (refused as queries, QueryDescriptorProblem),
//   and a network gives one vector for every such image;
// - or what structure it has at the scale places are recognised by is noise ("shows only
//   noise", BlindImageMeasure): the patch-normalised descriptor would amplify that noise
//   into a vector that is near no place and steadily nearest one (the places' means
//   correction; the filter then reads a robot standing still).
// Throws std::invalid_argument for another depth or channel count (ToGrayscale8).
std::string BlindImageProblem(const cv::Mat& image);

// What BlindImageProblem measures on the grey image (W x H, at least 32 x 16):
// - structure: the image averaged over cells (area resampling) w = min(64, W/2) columns wide
//   (the scale of the package's 64 x 32 descriptors), less its Gaussian blur of 2 cells (a
//   smooth field, such as vignetting, glare or the light through a lid, is no place), as a
//   root mean square in grey levels;
// - coarser: the same over cells twice as large (w/2 columns).
// A scene's structure holds from one scale to the next (natural images have about as much
// contrast in every octave of scale: their spectrum falls as 1/f), while noise's halves
// (its variance falls with the pixels a cell averages), whatever its correlation over fewer
// pixels than a cell (a demosaiced, denoised or JPEG-compressed sensor's). So with S the
// scene's variance and N the noise's at w columns, structure^2 = S + N and coarser^2 =
// S + N/4: S = (4 coarser^2 - structure^2) / 3 and N = 4 (structure^2 - coarser^2) / 3. The
// frame is blind when the scene's contrast sqrt(S) is under one step of the 8-bit scale (one
// grey level: what is left of a scene under a glare or a lid, seen only through the noise
// that dithers it), or when its contrast is under half the noise's (S < N / 4, that is
// coarser < structure sqrt(2/5); a dark tunnel frame of Nordland with a few lamps, whose
// points fall with scale as noise does, has S / N = 0.34). The repository's Nordland-100 frames (three seasons, at
// 64 x 32, 256 x 144 and ../shared's 640 x 360) give coarser / structure of at least 1.02 and a
// structure of at least 7.9 grey levels, and none of the 3000 Nordland 64 x 32 frames is
// blind; noise gives 0.5 (test_image_describer).
struct BlindImageMeasure {
  static constexpr double kStep = 1.0;  // one grey level
  double structure = 0, coarser = 0;
  int cells_wide = 0, cells_high = 0;
  // sqrt(S) and sqrt(N) above (0 where the estimate falls below 0).
  double scene() const;
  double noise() const;
  bool blind() const;
};
// Measured as above; nullopt for an image too small to measure (under 32 x 16 pixels).
std::optional<BlindImageMeasure> MeasureBlindImage(const cv::Mat& image);

// Builds the describer; an ONNX model is loaded and run once on a blank image, so that a
// missing, unreadable or incompatible model fails here (at start-up) with a message naming
// the file and the problem (std::runtime_error), not on the first image.
std::unique_ptr<ImageDescriber> MakeImageDescriber(const ImageDescriberOptions& options);

// Describes every image of ListImageFiles(folder), one row each; `blind`, if given, receives
// per row BlindImageProblem of its image ("" for a frame that shows something).
RowMatrixXf DescribeImageFolder(const std::string& folder, const ImageDescriber& describer,
                                std::vector<std::string>* blind = nullptr);

// Runs an ONNX model on a raw N x C x H x W float tensor and returns its output tensor
// (the model-loading and inference path without image preprocessing; for tests and tools).
cv::Mat RunOnnxTensor(const std::string& model_path, const cv::Mat& input,
                      const std::string& output_layer = "");

}  // namespace bsf_vpr
