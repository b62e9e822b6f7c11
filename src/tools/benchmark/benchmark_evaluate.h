// bsf_benchmark --sections evaluate: a whole offline evaluation as a user runs it
// (bsf_evaluate on .npy files), against the same method written in NumPy + OpenBLAS
// (scripts/numpy_bsf), both as separate processes on the same files, alternating.
#pragma once

#include <string>

#include "src/tools/benchmark/benchmark_util.h"

namespace bsf_vpr {
namespace tools {

// Writes the data once into `data_dir` (bsf_make_synthetic: 3 sets of N = 3000 / scale places,
// D = 4096 / scale, Q = N queries), then times `repeats` runs of each program; prints the
// medians, their ratio, the cores each kept busy and bsf_evaluate's phases, and
// "RESULTS DIFFER" if the two summaries are not the same.
void BenchmarkEvaluate(int repeats, int scale, const std::string& data_dir);

}  // namespace tools
}  // namespace bsf_vpr
