// The machine every figure is measured on, and a fair OpenBLAS for the baselines: the CPU's
// model and vector extensions, printed beside the figures, and an OpenBLAS kernel that fits
// the CPU when OpenBLAS's own detection does not know it (Debian 12's 0.3.21 runs its
// Prescott kernel, SSE3, on an Intel Xeon of 2023, which makes any comparison with it
// meaningless).
#pragma once

#include <string>

namespace bsf_vpr {
namespace tools {

struct CpuInfo {
  std::string model;   // "model name" of /proc/cpuinfo, e.g. "AMD EPYC 9B14"
  std::string vendor;  // "AuthenticAMD", "GenuineIntel"
  int family = 0, model_number = 0;
  std::string extensions;  // the vector extensions the CPU has, e.g. "avx2 fma avx512f ..."
  bool avx2 = false, avx512 = false;  // avx512: F, BW, DQ and VL
};
CpuInfo ReadCpuInfo();

// The OpenBLAS core type that fits the CPU's vector width: "SkylakeX" (AVX-512), "Haswell"
// (AVX2 + FMA), or "" (no better than OpenBLAS's own choice).
std::string FittingOpenBlasCore(const CpuInfo& cpu);

// Whether OpenBLAS's kernel `corename` (openblas_get_corename(), lower case compared) uses
// at least the vector width of `fitting`.
bool CoreFits(const std::string& corename, const std::string& fitting);

// At the start of a benchmark, before anything runs: when OPENBLAS_CORETYPE is not set and
// OpenBLAS's kernel does not fit the CPU, sets OPENBLAS_CORETYPE to the fitting core and
// runs the program again (OpenBLAS reads it when it is loaded); returns only if no re-run is
// needed. BSF_OPENBLAS_CHOSEN records the choice for the run that follows.
void EnsureFittingOpenBlas(char** argv);

// One line naming the CPU, its vector extensions and the OpenBLAS kernel in use (and
// whether it was chosen here, set by the user, or OpenBLAS's own). A kernel the user set that
// is narrower than the CPU's width is kept and flagged "NOT FAIR" (some hosts set
// OPENBLAS_CORETYPE=Haswell on AVX-512 CPUs that an old OpenBLAS does not know).
std::string MachineLine();

}  // namespace tools
}  // namespace bsf_vpr
