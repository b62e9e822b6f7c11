// The instruction sets the kernels are compiled for and the one a process runs them on. Every
// kernel is written once over Google Highway's vector types (distance_tiles-inl.h,
// distance_kernels.cpp, vector_math.cpp) and compiled once per target by foreach_target.h;
// the target is chosen at run time, here, by name:
//
//   "avx512_vnni"  Highway's AVX3_DL (AVX-512 with VNNI and the Ice Lake extensions)
//   "avx512"       AVX3 (AVX-512 F, VL, DQ, BW)
//   "avx2"         AVX2 with FMA and F16C
//   "neon"         aarch64 NEON
//   "portable"     one lane at a time in plain C++ (Highway's scalar fallback)
//
// Include this header before any Highway header: it fixes the set of targets (see below) for
// every translation unit that dispatches, which must agree on it.
#pragma once

// Every target the compiler can reach, the scalar one included (it is "portable", the kernel
// of a CPU without any of the others, and the reference the SIMD targets are tested against),
// AVX3_DL too (the int8 rows' VNNI). SSSE3 and SSE4 are left out: without FMA they would be a
// third rounding of the distances between "portable" and AVX2. SVE is left out: its vectors
// are sizeless types, which cannot be held in the arrays of sums the tiles keep; NEON runs on
// every aarch64 CPU and gives the same bits.
#ifndef HWY_COMPILE_ALL_ATTAINABLE
#define HWY_COMPILE_ALL_ATTAINABLE
#endif
#ifndef HWY_WANT_AVX3_DL
#define HWY_WANT_AVX3_DL
#endif
// The portable kernel is Highway's HWY_SCALAR (one lane) with every compiler: GCC before 12.3
// gets it anyway (HWY_EMU128 is broken there), and one fallback keeps one set of bits.
#undef HWY_BROKEN_EMU128
#define HWY_BROKEN_EMU128 1
#undef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS \
  (HWY_SSSE3 | HWY_SSE4 | HWY_SVE | HWY_SVE2 | HWY_SVE_256 | HWY_SVE2_128)

#include <hwy/targets.h>

#include <string>
#include <vector>

namespace bsf_vpr {
namespace kernels {

// The Highway dispatch state of the chosen target (the process-wide one of Highway is left
// alone: forcing a kernel here changes no other library's choice). Thread-safe.
hwy::ChosenTarget& ChosenTarget();

}  // namespace kernels
}  // namespace bsf_vpr

// The chosen target's entry of a table made by HWY_EXPORT(FUNC) in the same translation unit.
#define BSF_VPR_DISPATCH(FUNC) \
  (*(HWY_DISPATCH_TABLE(FUNC)[::bsf_vpr::kernels::ChosenTarget().GetIndex()]))
