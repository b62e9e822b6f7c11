// Force-included (-include) into src/core/distance_kernels.cpp by the sanitizer build only
// when clang++ refuses __builtin_cpu_supports("f16c") (clang before 16 does not know that
// feature string; g++ does). Answers "f16c" from CPUID leaf 1 and passes every other feature
// to the builtin, so that the core source builds unchanged.
#pragma once

#include <cpuid.h>

#include <cstring>

static inline bool BsfSanitizeCpuSupports(const char* feature) {
  if (std::strcmp(feature, "f16c") == 0) {
    unsigned eax, ebx, ecx, edx;
    return __get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_F16C) != 0;
  }
  if (std::strcmp(feature, "avx2") == 0) return __builtin_cpu_supports("avx2");
  if (std::strcmp(feature, "fma") == 0) return __builtin_cpu_supports("fma");
  return false;  // a feature this shim does not know: take the portable path
}

#define __builtin_cpu_supports(feature) BsfSanitizeCpuSupports(feature)
