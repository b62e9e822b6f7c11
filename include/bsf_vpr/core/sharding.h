// What a sharded map needs of the core besides the distances (LocalMap::Answer),
// the place layout (place_layout.h) and the decision (place_decider.h): a fingerprint that
// tells one loaded set from another.
//
// A sharded map keeps its reference sets on several shards (processes, possibly computers).
// Each shard computes the query's distances to its own sets; a combiner that holds every
// set's place layout (ids and poses, no descriptors) fuses them. The likelihood is a product
// over sets and each set's distances are computed alone, so the combiner's belief is bitwise
// the one a single recogniser holding every set gives (docs/sharding.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

// A 64-bit fingerprint of a set as held: its name, place ids, poses, precision and stored
// rows (the bytes the distances read). Equal for the same file loaded at the same storage
// precision; a set reloaded from a changed file, or at another precision, differs.
uint64_t SetFingerprint(const StoredReferenceSet& set);

}  // namespace bsf_vpr
