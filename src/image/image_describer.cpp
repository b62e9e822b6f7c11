#include "bsf_vpr/image/image_describer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>
#include <stdexcept>

#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"

namespace bsf_vpr {

void HogOptions::Validate() const {
  HogOptionsTable().CheckValues(*this);  // each field's bounds: cell_px >= 1 before the division
  if (width_px % cell_px != 0 || height_px % cell_px != 0 || width_px < 2 * cell_px ||
      height_px < 2 * cell_px) {
    throw std::invalid_argument(
        "hog_width_px and hog_height_px must be multiples of hog_cell_px (" +
        std::to_string(cell_px) + ") and at least two cells, got " + std::to_string(width_px) +
        " x " + std::to_string(height_px));
  }
}

int HogOptions::dimension() const {
  return (width_px / cell_px - 1) * (height_px / cell_px - 1) * 4 * bins;
}

void OnnxOptions::Validate() const {
  if (model_path.empty())
    throw std::invalid_argument("onnx_model is empty: the onnx descriptor needs a network (.onnx)");
  OnnxOptionsTable().CheckValues(*this);  // each field's bounds (onnx_std > 0)
  if (mean.size() != 3 || std.size() != 3) {
    throw std::invalid_argument("onnx_mean and onnx_std need 3 values (one per channel)");
  }
}

namespace {

class PatchNormDescriber : public ImageDescriber {
 public:
  explicit PatchNormDescriber(const PatchNormOptions& o) : o_(o) { o_.Validate(); }
  Eigen::VectorXf Describe(const cv::Mat& image) const override {
    return DescribePatchNormalized(image, o_);
  }
  int dimension() const override { return o_.dimension(); }
  std::string descriptor_type() const override { return o_.DescriptorType(); }

 private:
  PatchNormOptions o_;
};

class HogDescriber : public ImageDescriber {
 public:
  explicit HogDescriber(const HogOptions& o)
      : o_(o),
        hog_(cv::Size(o.width_px, o.height_px), cv::Size(2 * o.cell_px, 2 * o.cell_px),
             cv::Size(o.cell_px, o.cell_px), cv::Size(o.cell_px, o.cell_px), o.bins) {
    o_.Validate();
  }
  Eigen::VectorXf Describe(const cv::Mat& image) const override {
    cv::Mat small;
    cv::resize(ToGrayscale8(image), small, cv::Size(o_.width_px, o_.height_px), 0, 0,
               cv::INTER_AREA);
    std::vector<float> d;
    hog_.compute(small, d);
    return Eigen::Map<const Eigen::VectorXf>(d.data(), static_cast<Eigen::Index>(d.size()));
  }
  int dimension() const override { return o_.dimension(); }
  std::string descriptor_type() const override {
    return "hog_" + std::to_string(o_.width_px) + "x" + std::to_string(o_.height_px) + "_c" +
           std::to_string(o_.cell_px) + "_b" + std::to_string(o_.bins);
  }

 private:
  HogOptions o_;
  cv::HOGDescriptor hog_;
};

cv::dnn::Net LoadNet(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw std::runtime_error("ONNX model '" + path + "' does not exist");
  }
  try {
    cv::dnn::Net net = cv::dnn::readNetFromONNX(path);
    if (net.empty()) throw std::runtime_error("empty network");
    return net;
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot load ONNX model '" + path + "': " + e.what());
  }
}

class OnnxDescriber : public ImageDescriber {
 public:
  explicit OnnxDescriber(const OnnxOptions& o) : o_(o) {
    o_.Validate();
    net_ = LoadNet(o_.model_path);
    if (!o_.pca_path.empty()) pca_ = ReadNpyMatrix(o_.pca_path);
    // Run once now: an incompatible model or PCA fails at start-up, and fixes the dimension.
    const cv::Mat blank(o_.input_height_px, o_.input_width_px, CV_8UC3, cv::Scalar::all(127));
    try {
      dimension_ = static_cast<int>(Forward(blank).size());
    } catch (const std::exception& e) {
      throw std::runtime_error("ONNX model '" + o_.model_path + "' cannot describe a " +
                               std::to_string(o_.input_width_px) + "x" +
                               std::to_string(o_.input_height_px) + " RGB image: " + e.what());
    }
  }
  Eigen::VectorXf Describe(const cv::Mat& image) const override { return Forward(image); }
  int dimension() const override { return dimension_; }
  std::string descriptor_type() const override {
    return "onnx_" + std::filesystem::path(o_.model_path).stem().string() + "_" +
           std::to_string(dimension_);
  }

 private:
  Eigen::VectorXf Forward(const cv::Mat& image) const {
    cv::Mat resized, f;
    cv::resize(ToBgr8(image), resized, cv::Size(o_.input_width_px, o_.input_height_px), 0, 0,
               cv::INTER_AREA);
    if (o_.rgb) cv::cvtColor(resized, resized, cv::COLOR_BGR2RGB);
    resized.convertTo(f, CV_32F, 1.0 / 255.0);
    std::vector<cv::Mat> ch;
    cv::split(f, ch);
    for (int c = 0; c < 3; ++c) ch[c] = (ch[c] - o_.mean[c]) / o_.std[c];
    cv::merge(ch, f);
    const cv::Mat blob = cv::dnn::blobFromImage(f);  // 1 x 3 x H x W, no further scaling
    cv::Mat out;
    {
      MutexLock lock(&mutex_);  // cv::dnn::Net::forward is not const
      net_.setInput(blob);
      out = o_.output_layer.empty() ? net_.forward() : net_.forward(o_.output_layer);
    }
    const cv::Mat flat = out.reshape(1, 1);
    Eigen::VectorXf v = Eigen::Map<const Eigen::VectorXf>(flat.ptr<float>(),
                                                          static_cast<Eigen::Index>(flat.total()));
    if (pca_.size() > 0) {
      if (pca_.cols() != v.size()) {
        throw std::runtime_error("PCA matrix '" + o_.pca_path + "' is " +
                                 std::to_string(pca_.rows()) + " x " + std::to_string(pca_.cols()) +
                                 ", the network outputs " + std::to_string(v.size()) + " values");
      }
      v = pca_ * v;
    }
    if (!v.allFinite()) throw std::runtime_error("the network produced NaN or infinity");
    if (o_.l2_normalize && v.norm() > 0) v.normalize();
    return v;
  }

  OnnxOptions o_;
  mutable Mutex mutex_;
  mutable cv::dnn::Net net_ GUARDED_BY(mutex_);
  RowMatrixXf pca_;
  int dimension_ = 0;
};

}  // namespace

const OptionTable<HogOptions>& HogOptionsTable() {
  static const OptionTable<HogOptions> kTable =
      OptionTable<HogOptions>()
          .Add(
              "hog_width_px", [](auto& o) -> auto& { return o.width_px; },
              "hog: width the image is resized to (a multiple of hog_cell_px)", "px", AtLeast(1))
          .Add(
              "hog_height_px", [](auto& o) -> auto& { return o.height_px; },
              "hog: height the image is resized to (a multiple of hog_cell_px)", "px", AtLeast(1))
          .Add(
              "hog_cell_px", [](auto& o) -> auto& { return o.cell_px; },
              "hog: cell side; blocks are 2 x 2 cells moved by one cell", "px", AtLeast(1))
          .Add(
              "hog_bins", [](auto& o) -> auto& { return o.bins; }, "hog: orientation bins", "",
              AtLeast(1));
  return kTable;
}

const OptionTable<OnnxOptions>& OnnxOptionsTable() {
  static const OptionTable<OnnxOptions> kTable =
      OptionTable<OnnxOptions>()
          .Add("onnx_model", [](auto& o) -> auto& { return o.model_path; },
               "onnx: path of the network (.onnx); required for onnx", "", {})
          .Add(
              "onnx_input_width_px", [](auto& o) -> auto& { return o.input_width_px; },
              "onnx: network input width", "px", AtLeast(1))
          .Add(
              "onnx_input_height_px", [](auto& o) -> auto& { return o.input_height_px; },
              "onnx: network input height", "px", AtLeast(1))
          .Add(
              "onnx_mean", [](auto& o) -> auto& { return o.mean; },
              "onnx: per-channel mean of [0, 1] pixels, R,G,B (ImageNet's by default)")
          .Add(
              "onnx_std", [](auto& o) -> auto& { return o.std; },
              "onnx: per-channel standard deviation of [0, 1] pixels, R,G,B", "", Above(0))
          .Add(
              "onnx_rgb", [](auto& o) -> auto& { return o.rgb; },
              "onnx: feed R, G, B (false: B, G, R)")
          .Add(
              "onnx_output_layer", [](auto& o) -> auto& { return o.output_layer; },
              "onnx: output layer name (\"\": the network's output)")
          .Add(
              "onnx_pca_path", [](auto& o) -> auto& { return o.pca_path; },
              "onnx: K x D projection .npy applied to the output (\"\": none)")
          .Add(
              "onnx_l2_normalize", [](auto& o) -> auto& { return o.l2_normalize; },
              "onnx: L2-normalise the network output");
  return kTable;
}

const OptionTable<ImageDescriberOptions>& ImageDescriberOptionsTable() {
  static const OptionTable<ImageDescriberOptions> kTable =
      OptionTable<ImageDescriberOptions>()
          .AddChoice(
              "image_descriptor", [](auto& o) -> auto& { return o.kind; },
              "image descriptor: patchnorm (patch-normalised, downsampled image), hog or "
              "onnx (a network, e.g. NetVLAD exported to ONNX)",
              ImageDescriberKindNames())
          .Include(
              PatchNormOptionsTable(), [](auto& o) -> auto& { return o.patch_norm; })
          .Include(
              HogOptionsTable(), [](auto& o) -> auto& { return o.hog; })
          .Include(
              OnnxOptionsTable(), [](auto& o) -> auto& { return o.onnx; });
  return kTable;
}

void ValidateImageDescriberOptions(const ImageDescriberOptions& options) {
  options.patch_norm.Validate();
  if (options.kind == ImageDescriberKind::kHog) options.hog.Validate();
  if (options.kind == ImageDescriberKind::kOnnx) options.onnx.Validate();
}

const EnumNames<ImageDescriberKind>& ImageDescriberKindNames() {
  static const EnumNames<ImageDescriberKind> kNames{{ImageDescriberKind::kPatchNorm, "patchnorm"},
                                                    {ImageDescriberKind::kHog, "hog"},
                                                    {ImageDescriberKind::kOnnx, "onnx"}};
  return kNames;
}

ImageDescriberKind ParseImageDescriberKind(const std::string& name) {
  return ImageDescriberKindNames().Parse(name, "image_descriptor");
}

std::string ToString(ImageDescriberKind kind) { return ImageDescriberKindNames().Name(kind); }

std::unique_ptr<ImageDescriber> MakeImageDescriber(const ImageDescriberOptions& options) {
  switch (options.kind) {
    case ImageDescriberKind::kPatchNorm:
      return std::make_unique<PatchNormDescriber>(options.patch_norm);
    case ImageDescriberKind::kHog:
      return std::make_unique<HogDescriber>(options.hog);
    case ImageDescriberKind::kOnnx:
      return std::make_unique<OnnxDescriber>(options.onnx);
  }
  throw std::invalid_argument("unknown image descriptor kind");
}

RowMatrixXf DescribeImageFolder(const std::string& folder, const ImageDescriber& describer,
                                std::vector<std::string>* blind) {
  const std::vector<std::string> files = ListImageFiles(folder);
  RowMatrixXf out(static_cast<Eigen::Index>(files.size()), describer.dimension());
  if (blind != nullptr) blind->assign(files.size(), "");
  for (size_t i = 0; i < files.size(); ++i) {
    const cv::Mat img = cv::imread(files[i], cv::IMREAD_COLOR);
    if (img.empty()) throw std::runtime_error("cannot decode image '" + files[i] + "'");
    if (blind != nullptr) (*blind)[i] = BlindImageProblem(img);
    out.row(static_cast<Eigen::Index>(i)) = describer.Describe(img).transpose();
  }
  return out;
}

cv::Mat RunOnnxTensor(const std::string& model_path, const cv::Mat& input,
                      const std::string& output_layer) {
  cv::dnn::Net net = LoadNet(model_path);
  net.setInput(input);
  return (output_layer.empty() ? net.forward() : net.forward(output_layer)).clone();
}

namespace {

bool IsUniform(const cv::Mat& image) {
  const size_t pixel = image.elemSize();
  const uchar* first = image.ptr(0);
  for (int y = 0; y < image.rows; ++y) {
    const uchar* row = image.ptr(y);  // rows of a view need not follow each other
    for (int x = 0; x < image.cols; ++x) {
      if (std::memcmp(row + static_cast<size_t>(x) * pixel, first, pixel) != 0) return false;
    }
  }
  return true;
}

std::string Fixed2(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", v);
  return text;
}

}  // namespace

namespace {

// The root mean square of `grey` averaged over w columns of cells (area resampling), less its
// Gaussian blur of 2 cells; the cells' height in *h.
double CellStructure(const cv::Mat& grey, int w, int* h) {
  *h = std::max(2, static_cast<int>(std::lround(static_cast<double>(w) * grey.rows / grey.cols)));
  cv::Mat cells, smooth;
  cv::resize(grey, cells, cv::Size(w, *h), 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(cells, smooth, cv::Size(0, 0), 2.0, 2.0, cv::BORDER_REFLECT);
  return cv::norm(cells, smooth, cv::NORM_L2) / std::sqrt(static_cast<double>(cells.total()));
}

}  // namespace

double BlindImageMeasure::scene() const {
  return std::sqrt(std::max(0.0, (4 * coarser * coarser - structure * structure) / 3));
}

double BlindImageMeasure::noise() const {
  return std::sqrt(std::max(0.0, 4 * (structure * structure - coarser * coarser) / 3));
}

bool BlindImageMeasure::blind() const {
  return scene() < kStep || 5 * coarser * coarser < 2 * structure * structure;  // S < N / 4
}

std::optional<BlindImageMeasure> MeasureBlindImage(const cv::Mat& image) {
  if (image.empty() || image.cols < 32 || image.rows < 16) return std::nullopt;
  cv::Mat grey;
  ToGrayscale8(image).convertTo(grey, CV_32F);
  BlindImageMeasure m;
  m.cells_wide = std::min(64, grey.cols / 2);
  int coarse_high = 0;
  m.structure = CellStructure(grey, m.cells_wide, &m.cells_high);
  m.coarser = CellStructure(grey, m.cells_wide / 2, &coarse_high);
  return m;
}

std::string BlindImageProblem(const cv::Mat& image) {
  if (image.empty()) return "";  // the describers refuse it, saying so
  if (IsUniform(image)) {
    return "is uniform (all " + std::to_string(image.cols) + " x " + std::to_string(image.rows) +
           " pixels alike, as a covered or black camera gives): it shows nothing to recognise "
           "a place by";
  }
  const std::optional<BlindImageMeasure> m = MeasureBlindImage(image);
  if (!m || !m->blind()) return "";
  const std::string at =
      std::to_string(m->cells_wide) + " x " + std::to_string(m->cells_high) + " cells";
  if (m->scene() < BlindImageMeasure::kStep) {
    return "shows only noise (at " + at + " its scene's contrast is " + Fixed2(m->scene()) +
           " grey levels, under one step of the 8-bit scale, the noise's " + Fixed2(m->noise()) +
           "; as a covered, black or dazzled camera gives): it shows nothing to recognise a "
           "place by";
  }
  return "shows only noise (its structure falls from " + Fixed2(m->structure) + " grey levels at " +
         at + " to " + Fixed2(m->coarser) +
         " at cells twice as large, as noise does, where a scene's holds; as a covered, black "
         "or dazzled camera gives): it shows nothing to recognise a place by";
}

}  // namespace bsf_vpr
