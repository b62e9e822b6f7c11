// bsf_benchmark --sections large: one query against a map too large to search exactly at
// camera rate (M = 10 sets of N = 100,000 places, D = 4096, int8 storage: 4.1 GB), exact
// against the pca first stage with exact re-ranking (first_stage.h), in the same run.
#pragma once

#include "bsf_vpr/core/first_stage.h"

namespace bsf_vpr {
namespace tools {

// `scale` divides N (the --quick smoke test); `repeats` queries are timed per stage;
// `first_stage` is the pca stage timed against exact search.
void BenchmarkLarge(int repeats, int scale, const FirstStageOptions& first_stage);

}  // namespace tools
}  // namespace bsf_vpr
