// Reading reference sets for a map held in this process (local_map.h): load_reference_set's
// file, and the checks a set meets before it joins.
#pragma once

#include <string>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/map_backend.h"

namespace bsf_vpr {

// load_reference_set's file: `req`'s path read below `dir` (no lock needed), its name and
// condition overridden by the request's, memory-mapped as `options` say. Throws
// std::invalid_argument when there is no data directory (null) or the file cannot be a set.
ReferenceSet ReadRequestedSet(const DataDirectory* dir, const LoadRequest& req,
                              const ReadSetOptions& options = {});

// Throws std::invalid_argument when `set` (from `where`) declares a distance other than
// `metric`.
void CheckSetDistance(const StoredReferenceSet& set, DistanceMetric metric,
                      const std::string& where);

// Why descriptors of `type` should not be compared with `layout`'s sets ("" when they may):
// a set declares another descriptor type. An empty type (not declared) is never refused.
std::string TypeMismatch(const std::string& type, const PlaceLayout& layout);

// The set as list_reference_sets describes it (shard left empty).
SetSummary Summarize(const StoredReferenceSet& set);

}  // namespace bsf_vpr
