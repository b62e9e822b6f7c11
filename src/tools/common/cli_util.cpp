#include "src/tools/common/cli_util.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <stdexcept>

namespace bsf_vpr {
namespace tools {

double CpuSeconds(int who) {
  rusage u{};
  getrusage(who, &u);
  const auto seconds = [](const timeval& t) { return t.tv_sec + t.tv_usec * 1e-6; };
  return seconds(u.ru_utime) + seconds(u.ru_stime);
}

double ParseNumber(const std::string& flag, const std::string& value) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != value.size() || !std::isfinite(v)) {
    throw std::invalid_argument(flag + " expects a number, got '" + value + "'");
  }
  return v;
}

int ParseInteger(const std::string& flag, const std::string& value) {
  const double v = ParseNumber(flag, value);
  if (v != std::floor(v) || std::abs(v) > 1e9) {
    throw std::invalid_argument(flag + " expects an integer, got '" + value + "'");
  }
  return static_cast<int>(v);
}

void CreateFolders(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create folder '" + dir + "': " + ec.message());
}

void CreateParentFolders(const std::string& file) {
  const std::filesystem::path parent = std::filesystem::path(file).parent_path();
  if (!parent.empty()) CreateFolders(parent.string());
}

bool FlagReader::Next(std::string* flag, std::string* value) {
  if (i_ >= argc_) return false;
  *flag = argv_[i_];
  if (*flag == "-h" || *flag == "--help") {
    help_ = true;
    return false;
  }
  RefuseRenamedFlag(*flag);
  if (std::find(switches_.begin(), switches_.end(), *flag) != switches_.end()) {
    value->clear();
    ++i_;
    return true;
  }
  if (i_ + 1 >= argc_) throw std::invalid_argument(*flag + " needs a value");
  *value = argv_[i_ + 1];
  i_ += 2;
  return true;
}

void RefuseRenamedFlag(const std::string& flag) {
  static const std::vector<std::pair<std::string, std::string>> kRenamed = {
      {"--gamma", "--gamma-fraction G"},
      {"--seq-length", "--sequence-length L"},
      {"--seq-warmup", "--sequence-use-partial true|false"},
      {"--seq-min-velocity", "--sequence-min-velocity V"},
      {"--seq-max-velocity", "--sequence-max-velocity V"},
      {"--seq-velocity-step", "--sequence-velocity-step V"},
      {"--filter-step", "--filter-step-mean-places S"},
      {"--filter-std", "--filter-step-std-places S"},
      {"--relocalization", "--relocalization-probability R"},
      {"--descriptor", "--image-descriptor patchnorm|hog|onnx"},
      {"--patch-width", "--patch-width-px W"},
      {"--patch-height", "--patch-height-px H"},
      {"--patch-size", "--patch-size-px P"},
      {"--hog-width", "--hog-width-px W"},
      {"--hog-height", "--hog-height-px H"},
      {"--hog-cell", "--hog-cell-px C"},
      {"--onnx-input", "--onnx-input-width-px W --onnx-input-height-px H"},
      {"--onnx-output", "--onnx-output-layer NAME"},
      {"--onnx-pca", "--onnx-pca-path PATH"},
      {"--onnx-bgr", "--onnx-rgb false"},
      {"--onnx-no-l2", "--onnx-l2-normalize false"},
  };
  for (const auto& [old_flag, now] : kRenamed) {
    if (flag == old_flag) {
      throw std::invalid_argument(flag + " was renamed: use " + now +
                                  " (options have the names of the ROS parameters)");
    }
  }
}

int RunTool(const char* tool, int (*run)(int, char**), int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << tool << ": error: " << e.what() << '\n';
    return kExitBadInput;
  }
}

}  // namespace tools
}  // namespace bsf_vpr
