#include "describer_flags.h"

#include <sstream>
#include <stdexcept>

#include "cli_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

std::vector<float> ParseTriple(const std::string& flag, const std::string& value) {
  std::vector<float> v;
  std::stringstream ss(value);
  for (std::string item; std::getline(ss, item, ',');)
    v.push_back(static_cast<float>(ParseNumber(flag, item)));
  return v;  // OnnxOptions::Validate checks that there are three
}

std::string Join(const std::vector<float>& values) {
  std::ostringstream out;
  for (size_t i = 0; i < values.size(); ++i) out << (i ? "," : "") << values[i];
  return out.str();
}

}  // namespace

const std::vector<std::string>& DescriberSwitches() {
  static const std::vector<std::string> kSwitches = {"--onnx-bgr", "--onnx-no-l2"};
  return kSwitches;
}

bool ParseDescriberSwitch(const std::string& flag, ImageDescriberOptions* options) {
  if (flag == "--onnx-bgr") {
    options->onnx.rgb = false;
  } else if (flag == "--onnx-no-l2") {
    options->onnx.l2_normalize = false;
  } else {
    return false;
  }
  return true;
}

bool ParseDescriberFlag(const std::string& flag, const std::string& value,
                        ImageDescriberOptions* options) {
  ImageDescriberOptions& d = *options;
  if (flag == "--descriptor") {
    try {
      d.kind = ParseImageDescriberKind(value);
    } catch (const std::invalid_argument&) {
      throw std::invalid_argument("unknown --descriptor '" + value +
                                  "' (expected patchnorm, hog or onnx)");
    }
  } else if (flag == "--patch-width") {
    d.patch_norm.width_px = ParseInteger(flag, value);
  } else if (flag == "--patch-height") {
    d.patch_norm.height_px = ParseInteger(flag, value);
  } else if (flag == "--patch-size") {
    d.patch_norm.patch_size_px = ParseInteger(flag, value);
  } else if (flag == "--hog-width") {
    d.hog.width_px = ParseInteger(flag, value);
  } else if (flag == "--hog-height") {
    d.hog.height_px = ParseInteger(flag, value);
  } else if (flag == "--hog-cell") {
    d.hog.cell_px = ParseInteger(flag, value);
  } else if (flag == "--hog-bins") {
    d.hog.bins = ParseInteger(flag, value);
  } else if (flag == "--onnx-model") {
    d.onnx.model_path = value;
  } else if (flag == "--onnx-input") {
    const size_t x = value.find('x');
    if (x == std::string::npos)
      throw std::invalid_argument("--onnx-input expects WxH, got '" + value + "'");
    d.onnx.input_width_px = ParseInteger(flag, value.substr(0, x));
    d.onnx.input_height_px = ParseInteger(flag, value.substr(x + 1));
  } else if (flag == "--onnx-mean") {
    d.onnx.mean = ParseTriple(flag, value);
  } else if (flag == "--onnx-std") {
    d.onnx.std = ParseTriple(flag, value);
  } else if (flag == "--onnx-output") {
    d.onnx.output_layer = value;
  } else if (flag == "--onnx-pca") {
    d.onnx.pca_path = value;
  } else {
    return false;
  }
  return true;
}

void ValidateDescriberOptions(const ImageDescriberOptions& options) {
  options.patch_norm.Validate();
  if (options.kind == ImageDescriberKind::kHog) options.hog.Validate();
  if (options.kind == ImageDescriberKind::kOnnx) options.onnx.Validate();
}

std::string DescriberUsage() {
  const ImageDescriberOptions d;
  const PatchNormOptions& p = d.patch_norm;
  const HogOptions& h = d.hog;
  const OnnxOptions& o = d.onnx;
  std::ostringstream u;
  u << "  --descriptor NAME       image descriptor for image folders: patchnorm, hog or onnx\n"
    << "                          (default " << ToString(d.kind) << ")\n"
    << "  --patch-width W, --patch-height H, --patch-size P\n"
    << "                          patchnorm: resize and patch size (default " << p.width_px << " "
    << p.height_px << " " << p.patch_size_px << ")\n"
    << "  --hog-width W, --hog-height H, --hog-cell C, --hog-bins B\n"
    << "                          hog: resize, cell size and orientation bins (default "
    << h.width_px << " " << h.height_px << " " << h.cell_px << " " << h.bins << ")\n"
    << "  --onnx-model PATH       onnx: the network (e.g. NetVLAD exported to ONNX)\n"
    << "  --onnx-input WxH        onnx: input size (default " << o.input_width_px << "x"
    << o.input_height_px << ")\n"
    << "  --onnx-mean R,G,B, --onnx-std R,G,B   onnx: per-channel normalisation of [0, 1]\n"
    << "                          pixels (default ImageNet's " << Join(o.mean) << " and "
    << Join(o.std) << ")\n"
    << "  --onnx-output NAME      onnx: output layer (default: the network's output)\n"
    << "  --onnx-pca PATH         onnx: K x D projection .npy applied to the output\n"
    << "  --onnx-bgr              onnx: feed B, G, R instead of R, G, B\n"
    << "  --onnx-no-l2            onnx: do not L2-normalise the output\n";
  return u.str();
}

ReferenceSet DescribeImageFolderAsSet(const std::string& folder, const std::string& name,
                                      const ImageDescriber& describer) {
  ReferenceSet set = MakeReferenceSet(name, DescribeImageFolder(folder, describer));
  set.descriptor_type = describer.descriptor_type();
  return set;
}

}  // namespace tools
}  // namespace bsf_vpr
