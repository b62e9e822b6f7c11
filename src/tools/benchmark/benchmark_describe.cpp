#include "src/tools/benchmark/benchmark_describe.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "bsf_vpr/image/image_describer.h"
#include "bsf_vpr/io/file_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

using Clock = std::chrono::steady_clock;

volatile float g_sink;  // keeps the timed work from being optimised away

double Ms(Clock::time_point t0, Clock::time_point t1) {
  return std::chrono::duration<double, std::milli>(t1 - t0).count();
}

// The value at fraction p of the sorted values (nearest rank), as pipeline_benchmark reports.
double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5)];
}

struct Images {
  std::vector<cv::Mat> decoded;  // BGR, as cv::imread gives them (and ingest receives bgr8)
  std::vector<double> decode_ms;
};

// The file's bytes are read first, so that the decode time leaves the disk out.
Images Decode(const std::string& folder, size_t limit) {
  const std::vector<std::string> files = ListImageFiles(folder);
  if (files.empty()) throw std::runtime_error("no images in '" + folder + "'");
  Images out;
  for (size_t i = 0; i < std::min(limit, files.size()); ++i) {
    std::ifstream in(files[i], std::ios::binary);
    const std::vector<uchar> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
    const Clock::time_point t0 = Clock::now();
    cv::Mat image = cv::imdecode(bytes, cv::IMREAD_COLOR);
    out.decode_ms.push_back(Ms(t0, Clock::now()));
    if (image.empty()) throw std::runtime_error("cannot decode image '" + files[i] + "'");
    out.decoded.push_back(std::move(image));
  }
  return out;
}

struct Case {
  std::string onnx_label;  // "onnx <model>"; the other describers are named by their type
  ImageDescriberOptions options;
  cv::Size input;  // the size the describer resizes the image to
  bool gray;       // whether it resizes a grayscale copy (patchnorm, hog) or the BGR image
};

std::vector<Case> Cases(const std::string& models_dir) {
  std::vector<Case> cases;
  ImageDescriberOptions patchnorm;
  patchnorm.kind = ImageDescriberKind::kPatchNorm;
  cases.push_back({"", patchnorm,
                   cv::Size(patchnorm.patch_norm.width_px, patchnorm.patch_norm.height_px), true});
  ImageDescriberOptions hog;
  hog.kind = ImageDescriberKind::kHog;
  cases.push_back({"", hog, cv::Size(hog.hog.width_px, hog.hog.height_px), true});
  for (const char* model : {"resnet50_light", "squeezenet_light"}) {
    ImageDescriberOptions onnx;
    onnx.kind = ImageDescriberKind::kOnnx;
    onnx.onnx.model_path = models_dir + "/" + model + "/model.onnx";
    cases.push_back({std::string("onnx ") + model, onnx,
                     cv::Size(onnx.onnx.input_width_px, onnx.onnx.input_height_px), false});
  }
  return cases;
}

// The baseline: the image brought to the describer's input as the describer does it first
// (a grayscale describer converts, then resizes the one channel; ONNX resizes the BGR image).
void Resize(const Case& c, const cv::Mat& image, cv::Mat* gray, cv::Mat* small) {
  if (c.gray) {
    cv::cvtColor(image, *gray, cv::COLOR_BGR2GRAY);
    cv::resize(*gray, *small, c.input, 0, 0, cv::INTER_AREA);
  } else {
    cv::resize(image, *small, c.input, 0, 0, cv::INTER_AREA);
  }
}

// Times `c` on every image `repeats` times, each describe right after the baseline on the
// same image, and prints one line.
void TimeCase(const Case& c, const std::vector<cv::Mat>& images, int repeats) {
  if (c.options.kind == ImageDescriberKind::kOnnx &&
      !std::filesystem::is_regular_file(c.options.onnx.model_path)) {
    std::printf("describe  %-24s skipped: no model at %s\n", c.onnx_label.c_str(),
                c.options.onnx.model_path.c_str());
    return;
  }
  const std::unique_ptr<ImageDescriber> describer = MakeImageDescriber(c.options);
  const std::string label = c.onnx_label.empty() ? describer->descriptor_type() : c.onnx_label;
  cv::Mat gray, small;
  Resize(c, images[0], &gray, &small);  // warm-up, not timed
  g_sink = describer->Describe(images[0])(0);
  std::vector<std::vector<double>> describe(images.size()), resize(images.size());
  for (int r = 0; r < repeats; ++r) {
    for (size_t i = 0; i < images.size(); ++i) {
      const Clock::time_point t0 = Clock::now();
      Resize(c, images[i], &gray, &small);
      const Clock::time_point t1 = Clock::now();
      g_sink = small.at<uchar>(0, 0);
      const Clock::time_point t2 = Clock::now();
      g_sink = describer->Describe(images[i])(0);
      const Clock::time_point t3 = Clock::now();
      resize[i].push_back(Ms(t0, t1));
      describe[i].push_back(Ms(t2, t3));
    }
  }
  std::vector<double> describe_ms, resize_ms;  // one per image: its median over the repeats
  for (size_t i = 0; i < images.size(); ++i) {
    describe_ms.push_back(Percentile(describe[i], 0.5));
    resize_ms.push_back(Percentile(resize[i], 0.5));
  }
  const double d50 = Percentile(describe_ms, 0.5), r50 = Percentile(resize_ms, 0.5);
  std::printf(
      "describe  %-24s input %dx%d, D=%d: %.3f ms per image (p90 %.3f); %s to %dx%d "
      "alone %.3f ms (p90 %.3f): %.2fx the resize\n",
      label.c_str(), c.input.width, c.input.height, describer->dimension(), d50,
      Percentile(describe_ms, 0.9), c.gray ? "cv::cvtColor to gray + cv::resize" : "cv::resize",
      c.input.width, c.input.height, r50, Percentile(resize_ms, 0.9), d50 / r50);
}

// Times the ingest's blind-frame check (BlindImageProblem) on every image, and prints one
// line with its ratio to decoding the image.
void TimeBlindCheck(const std::vector<cv::Mat>& images, int repeats, double decode_ms) {
  std::vector<double> per_image;
  int blind = 0;
  for (const cv::Mat& image : images) {
    std::vector<double> ms;
    for (int r = 0; r < repeats; ++r) {
      const Clock::time_point t0 = Clock::now();
      const std::string why = BlindImageProblem(image);
      ms.push_back(Ms(t0, Clock::now()));
      if (r == 0) blind += !why.empty();
    }
    per_image.push_back(Percentile(ms, 0.5));
  }
  const double b50 = Percentile(per_image, 0.5);
  std::printf(
      "describe  blind check (BlindImageProblem, the ingest's, before any describer): %.3f ms "
      "per image (p90 %.3f): %.2fx cv::imdecode; %d of %zu images found blind\n",
      b50, Percentile(per_image, 0.9), b50 / decode_ms, blind, images.size());
}

}  // namespace

void BenchmarkDescribe(int repeats, int scale, const std::string& folder,
                       const std::string& models_dir) {
  const Images images = Decode(folder, static_cast<size_t>(100 / scale));
  const cv::Size size = images.decoded[0].size();
  bool same_size = true;
  for (const cv::Mat& m : images.decoded) same_size = same_size && m.size() == size;
  std::printf(
      "describe  %zu images of %dx%d%s from %s, decoded once: cv::imdecode %.3f ms per image "
      "(p90 %.3f); OpenCV on %d threads; each describer on the BGR image, against "
      "bringing the same image to its input size as it does first (cv::resize INTER_AREA)\n",
      images.decoded.size(), size.width, size.height, same_size ? "" : " (sizes differ)",
      folder.c_str(), Percentile(images.decode_ms, 0.5), Percentile(images.decode_ms, 0.9),
      cv::getNumThreads());
  TimeBlindCheck(images.decoded, repeats, Percentile(images.decode_ms, 0.5));
  for (const Case& c : Cases(models_dir)) TimeCase(c, images.decoded, repeats);
}

}  // namespace tools
}  // namespace bsf_vpr
