// bsf_benchmark --sections joint: what the joint representation of the sets costs
// (joint_representation.h): a query of the default bsf with its discriminant against the
// default without it (fusion_joint none), timed in turn; the representations' builds at
// M = 3, N = 3000, D = 4096; and the discriminant's build at M = 10, N = 100,000, D = 4096
// (int8 rows, 4.1 GB), with the resident memory it took.
#pragma once

namespace bsf_vpr {
namespace tools {

// `scale` divides N (the --quick smoke test); `repeats` rounds are timed.
void BenchmarkJoint(int repeats, int scale);

}  // namespace tools
}  // namespace bsf_vpr
