// Reading the reference sets a fusion node or a fusion shard is configured with, and the
// distance they are compared with: the parts of start-up and load_reference_set that both
// share.
#pragma once

#include <bsf_vpr/LoadReferenceSet.h>

#include <string>
#include <vector>

#include "bsf_vpr/core/place_recognizer.h"
#include "bsf_vpr/io/data_directory.h"
#include "src/ros/fusion/fusion_params.h"

namespace bsf_vpr {

// Reads params->reference_sets (paths relative to data_directory, or the working directory
// without one, absolute, or package://PACKAGE/PATH inside a ROS package: the operator's own
// configuration, not confined like service requests),
// takes the distance they declare when none is configured (params->recognizer.metric), and
// adds them to `recognizer` at params' storage and pose tolerance, logging each. Throws
// std::exception naming the file, or the sets' disagreeing distances.
void LoadConfiguredSets(FusionParams* params, PlaceRecognizer* recognizer);
// A configured set's path as a file name: package://PACKAGE/PATH (as camera_info_url and
// rviz resources name files) in the package's folder, a relative path below `base`.
// Throws std::invalid_argument for a package ROS does not find.
std::string ResolveConfiguredPath(const std::string& base, const std::string& path);

// load_reference_set's file: `req`'s path read below `dir` (no lock needed), its name and
// condition overridden by the request's. Throws std::invalid_argument when there is no data
// directory (null) or the file cannot be a set.
ReferenceSet ReadRequestedSet(const DataDirectory* dir, const LoadReferenceSet::Request& req);

// Before adding `set` (from `where`): with no distance configured and nothing loaded yet,
// adopts the distance it declares (params and recognizer, logged); else throws
// std::invalid_argument when it is meant for another distance than the recognizer's.
void TakeSetDistance(const ReferenceSet& set, const std::string& where, FusionParams* params,
                     PlaceRecognizer* recognizer);

// Why descriptors of `type` should not be compared with `map`'s sets ("" when they may):
// a set declares another descriptor type. An empty type (not declared) is never refused.
std::string DescriptorTypeMismatch(const std::string& type, const ReferenceMap& map);

// Builds the first stage's index for the recogniser's sets now (first_stage pca) and logs
// it, warning when its basis keeps under 99% of the rows' energy. Never throws: a failed
// build (memory) switches recognizer and params to exact search, logged and kept in *error.
void PrepareFirstStageOrFallBack(PlaceRecognizer* recognizer, FusionParams* params,
                                 std::string* error);

}  // namespace bsf_vpr
