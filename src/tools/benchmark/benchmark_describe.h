// bsf_benchmark --sections describe: the first step of the image path, descriptor_ingest's
// describer (image_describer.h), at the images' own resolution. Each describer is timed per
// image against bringing the same image to that describer's input size alone (cv::resize; for
// the grayscale describers, patchnorm and hog, cv::cvtColor to gray first, as they do): the
// part no describer can skip, measured in the same run.
#pragma once

#include <string>

namespace bsf_vpr {
namespace tools {

// Reads the image files of `folder` (ListImageFiles; the first 100 / scale) into memory and
// decodes each once (cv::imdecode, timed). Then times, `repeats` times over every image,
// alternating with the resize baseline: patchnorm and hog with their default options, and
// onnx with resnet50_light and squeezenet_light from `models_dir` (a missing model is
// reported and skipped). Prints per describer the median and p90 over the images (each
// image's median over the repeats), the baseline's, and the ratio of the medians.
void BenchmarkDescribe(int repeats, int scale, const std::string& folder,
                       const std::string& models_dir);

}  // namespace tools
}  // namespace bsf_vpr
