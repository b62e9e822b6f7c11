// bsf_benchmark --sections offmap: what the hypothesis "no place of the map" costs
// (off_map.h): a query of the default bsf, and of bsf+filter, against the same with
// off_map false, timed in turn, at M = 3, N = 3000, D = 4096.
#pragma once

namespace bsf_vpr {
namespace tools {

// `scale` divides N (the --quick smoke test); `repeats` rounds are timed.
void BenchmarkOffMap(int repeats, int scale);

}  // namespace tools
}  // namespace bsf_vpr
