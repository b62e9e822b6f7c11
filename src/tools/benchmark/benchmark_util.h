// What every bsf_benchmark section reports with: the median of its repeats, a timed median,
// the process's resident memory and the memory available.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "bsf_vpr/core/types.h"

namespace bsf_vpr {
namespace tools {

// Uniform values in [-1, 1) from xorshift64*: a 4 GB map is made in seconds (a normal
// generator would take minutes). Random rows have no low-dimensional structure, so the
// first stage's error (or a joint representation's) is far worse than on real descriptors:
// the sections that use them measure time only; accuracy on real data is in
// docs/performance.md, docs/results.md and the tests.
inline RowMatrixXf Uniform(int rows, int cols, uint64_t seed) {
  RowMatrixXf m(rows, cols);
  uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    const uint64_t r = x * 0x2545F4914F6CDD1Dull;
    m.data()[i] = static_cast<float>(static_cast<int64_t>(r >> 40) - (1 << 23)) / (1 << 23);
  }
  return m;
}

// The median of `v` (the upper one of an even count).
inline double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Median wall time of `fn` in milliseconds over `repeats` runs (after one warm-up run).
inline double TimeMs(int repeats, const std::function<void()>& fn) {
  fn();
  std::vector<double> ms;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  return Median(ms);
}

// Several commands timed in turn, `repeats` rounds of one run of each (after a warm-up run of
// each), so that a slow spell of a shared machine falls on all of them alike: per command,
// its time in each round (ms).
inline std::vector<std::vector<double>> InterleavedTimesMs(
    int repeats, const std::vector<std::function<void()>>& fns) {
  for (const auto& fn : fns) fn();
  std::vector<std::vector<double>> ms(fns.size());
  for (int r = 0; r < repeats; ++r) {
    for (size_t k = 0; k < fns.size(); ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      fns[k]();
      ms[k].push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
  }
  return ms;
}

// The median over rounds of a[r] / b[r] (two commands' times from InterleavedTimesMs).
inline double MedianRatio(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> ratio;
  for (size_t r = 0; r < a.size() && r < b.size(); ++r) ratio.push_back(a[r] / b[r]);
  return Median(ratio);
}

// Resident memory of this process, bytes (VmRSS).
inline size_t ResidentBytes() {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stoul(line.substr(6)) * 1024;
  }
  return 0;
}

// Bytes of memory the kernel reports available (MemAvailable), 0 if unknown.
inline double AvailableBytes() {
  std::ifstream in("/proc/meminfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("MemAvailable:", 0) == 0) return std::stod(line.substr(13)) * 1024;
  }
  return 0;
}

}  // namespace tools
}  // namespace bsf_vpr
