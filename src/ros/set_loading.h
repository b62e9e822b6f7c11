// Reading the reference sets a fusion node or a fusion shard is configured with, and the
// distance they are compared with: the parts of start-up and load_reference_set that both
// share.
#pragma once

#include <string>
#include <vector>

#include "bsf_vpr/core/place_recognizer.h"
#include "fusion_params.h"

namespace bsf_vpr {

struct ConfiguredSet {
  ReferenceSet set;
  std::string path;  // the file it was read from
};

// Reads params.reference_sets, paths relative to params.data_directory (or the working
// directory without one): the operator's own configuration, not confined like service
// requests. Throws std::exception naming the file.
std::vector<ConfiguredSet> ReadConfiguredSets(const FusionParams& params);

// With no distance configured, sets params->recognizer.metric to the one the sets declare.
// Throws std::invalid_argument when they declare different ones.
void ChooseDeclaredDistance(const std::vector<ConfiguredSet>& sets, FusionParams* params);

// With no distance configured and nothing loaded yet, adopts the distance `set` declares
// (params and recognizer); returns whether it did.
bool AdoptDistanceOfFirstSet(const ReferenceSet& set, FusionParams* params,
                             PlaceRecognizer* recognizer);

// Throws std::invalid_argument when `set` is meant for another distance than `metric`;
// `where` names its file in the message.
void CheckSetDistance(const ReferenceSet& set, DistanceMetric metric, const std::string& where);

// Builds the first stage's index for the recogniser's sets now (first_stage pca) and logs
// it, warning when its basis keeps under 99% of the rows' energy. Never throws: a failed
// build (memory) switches recognizer and params to exact search, logged and kept in *error.
void PrepareFirstStageOrFallBack(PlaceRecognizer* recognizer, FusionParams* params,
                                 std::string* error);

}  // namespace bsf_vpr
