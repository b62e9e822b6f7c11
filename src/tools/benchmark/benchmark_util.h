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

namespace bsf_vpr {
namespace tools {

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
