// A configured set's file as the operator names it in the parameters (reference_sets).
#pragma once

#include <string>

namespace bsf_vpr {

// A configured set's path as a file name: package://PACKAGE/PATH (as camera_info_url and
// rviz resources name files) in the package's folder, a relative path below `base`
// (configured paths are the operator's own configuration, not confined like service
// requests). Throws std::invalid_argument for a package ROS does not find.
std::string ResolveConfiguredPath(const std::string& base, const std::string& path);

}  // namespace bsf_vpr
