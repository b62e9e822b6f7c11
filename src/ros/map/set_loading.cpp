#include "src/ros/map/set_loading.h"

#include <ros/console.h>
#include <ros/package.h>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"

namespace bsf_vpr {

void CheckSetDistance(const ReferenceSet& set, DistanceMetric metric, const std::string& where) {
  const std::string name = ToString(metric);
  if (!set.distance.empty() && set.distance != name) {
    throw std::invalid_argument("reference set '" + set.name + "' (" + where + ") is meant for " +
                                set.distance + " distance, the node uses " + name);
  }
}

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

ReferenceSet ReadRequestedSet(const DataDirectory* dir, const LoadReferenceSet::Request& req) {
  if (!dir) {
    throw std::invalid_argument("no data directory is configured (parameter data_directory)");
  }
  ReferenceSet set = LoadReferenceSetFile(*dir, req.path, req.name);
  if (!req.condition.empty()) set.condition = req.condition;
  return set;
}

std::string TypeMismatch(const std::string& type, const PlaceLayout& layout) {
  if (type.empty()) return "";
  for (const SetLayout& s : layout.sets()) {
    if (!s.descriptor_type.empty() && s.descriptor_type != type) {
      return "descriptors of type " + QuotedForMessage(type, 60) + " meet set '" + s.name +
             "' of type '" + s.descriptor_type + "'";
    }
  }
  return "";
}

}  // namespace bsf_vpr
