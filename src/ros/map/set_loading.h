// Reading reference sets for a map held in this process (local_map.h): the configured
// sets' paths, load_reference_set's file, and the checks a set meets before it joins.
#pragma once

#include <bsf_vpr/LoadReferenceSet.h>

#include <string>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"

namespace bsf_vpr {

// A configured set's path as a file name: package://PACKAGE/PATH (as camera_info_url and
// rviz resources name files) in the package's folder, a relative path below `base`
// (configured paths are the operator's own configuration, not confined like service
// requests). Throws std::invalid_argument for a package ROS does not find.
std::string ResolveConfiguredPath(const std::string& base, const std::string& path);

// load_reference_set's file: `req`'s path read below `dir` (no lock needed), its name and
// condition overridden by the request's. Throws std::invalid_argument when there is no data
// directory (null) or the file cannot be a set.
ReferenceSet ReadRequestedSet(const DataDirectory* dir, const LoadReferenceSet::Request& req);

// Throws std::invalid_argument when `set` (from `where`) declares a distance other than
// `metric`.
void CheckSetDistance(const ReferenceSet& set, DistanceMetric metric, const std::string& where);

// Why descriptors of `type` should not be compared with `layout`'s sets ("" when they may):
// a set declares another descriptor type. An empty type (not declared) is never refused.
std::string TypeMismatch(const std::string& type, const PlaceLayout& layout);

}  // namespace bsf_vpr
