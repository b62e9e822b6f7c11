#include "src/ros/map/configured_paths.h"

#include <ros/package.h>

#include <stdexcept>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/file_util.h"

namespace bsf_vpr {

std::string ResolveConfiguredPath(const std::string& base, const std::string& path) {
  constexpr char kScheme[] = "package://";
  if (path.rfind(kScheme, 0) != 0) return ResolvePath(base, path);
  const std::string rest = path.substr(sizeof(kScheme) - 1);
  const size_t slash = rest.find('/');
  const std::string package = rest.substr(0, slash);
  const std::string folder = package.empty() ? "" : ros::package::getPath(package);
  if (folder.empty()) {
    throw std::invalid_argument("reference set path " + QuotedForMessage(path) + " names package " +
                                QuotedForMessage(package) +
                                ", which ROS does not find (ROS_PACKAGE_PATH)");
  }
  return slash == std::string::npos ? folder : folder + rest.substr(slash);
}

}  // namespace bsf_vpr
