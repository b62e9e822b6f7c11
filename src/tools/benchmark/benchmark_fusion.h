// bsf_benchmark --sections fusion: selection + likelihoods + posterior for M = 3, N = 3000
// given the distances, against the paper's formulas written straightforwardly (O(N^2)).
#pragma once

namespace bsf_vpr {
namespace tools {

// `scale` divides N (the --quick smoke test); `repeats` rounds are timed.
void BenchmarkFusion(int repeats, int scale);

}  // namespace tools
}  // namespace bsf_vpr
