// bsf_benchmark --sections mapped: a map whose sets are memory-mapped (int8 .npy files as
// bsf_store_set writes them) against the same sets read into memory, in one run: the time to
// open one set, the resident memory of the whole map, a query's time with the pca first
// stage, and the beliefs' delay while a load builds the index in the background.
#pragma once

#include <string>

#include "bsf_vpr/core/first_stage.h"

namespace bsf_vpr {
namespace tools {

// M sets of N x D int8 rows (random: time only) written once below `dir` (reused when
// there); `scale` divides N (--quick); `repeats` queries are timed per measure.
void BenchmarkMapped(int repeats, int scale, const FirstStageOptions& first_stage,
                     const std::string& dir);

}  // namespace tools
}  // namespace bsf_vpr
