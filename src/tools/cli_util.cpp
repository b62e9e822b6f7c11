#include "cli_util.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <stdexcept>

namespace bsf_vpr {
namespace tools {

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
