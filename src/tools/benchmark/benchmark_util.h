// What every bsf_benchmark section reports with: the median of its repeats, a timed median,
// the process's resident memory and the memory available.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/core/types.h"
#include "bsf_vpr/map/place_recognizer.h"

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

// Milliseconds since `t0`.
inline double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
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

// A query of two recognisers made with `options_a` and `options_b` over the same M sets of
// N x D uniform rows (seeds set_seed, set_seed + 1, ...), each fed its own stream of 32
// uniform queries (seed query_seed) in order, eight a round, the rounds timed in turn
// (InterleavedTimesMs): per recogniser the ms a query of each round, and the seconds of a's
// first query (whatever it builds on its first query), made before the rounds.
struct PairedQueryTimes {
  std::vector<double> a_ms, b_ms;
  double a_first_s = 0;
};
inline PairedQueryTimes TimePairedQueries(const RecognizerOptions& options_a,
                                          const RecognizerOptions& options_b, int repeats, int m,
                                          int n, int d, uint64_t set_seed, uint64_t query_seed) {
  PlaceRecognizer a(options_a), b(options_b);
  for (int u = 0; u < m; ++u) {
    const RowMatrixXf rows = Uniform(n, d, set_seed + static_cast<uint64_t>(u));
    a.AddReferenceSet(MakeReferenceSet("s" + std::to_string(u), rows));
    b.AddReferenceSet(MakeReferenceSet("s" + std::to_string(u), rows));
  }
  const RowMatrixXf queries = Uniform(32, d, query_seed);
  constexpr int kCalls = 8;
  int next_a = 0, next_b = 0;
  const auto stream = [&queries](PlaceRecognizer* r, int* next) {
    return [r, next, &queries] {
      for (int c = 0; c < kCalls; ++c) {
        r->Recognize(queries.row((*next)++ % queries.rows()).transpose(), true);
      }
    };
  };
  PairedQueryTimes out;
  const auto t0 = std::chrono::steady_clock::now();
  a.Recognize(queries.row(0).transpose(), true);
  out.a_first_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<std::vector<double>> ms =
      InterleavedTimesMs(repeats, {stream(&a, &next_a), stream(&b, &next_b)});
  for (std::vector<double>& t : ms) {
    for (double& v : t) v /= kCalls;
  }
  out.a_ms = std::move(ms[0]);
  out.b_ms = std::move(ms[1]);
  return out;
}

// A recogniser's sets searched through a first stage built here (its index timed apart from
// the map that holds it): each query as PlaceRecognizer::Recognize would take it with that
// first stage, the distances through `stage`, the joint representation's if the method
// needs one, and the decision. Made before PlaceRecognizer::ReadSets (it asks the
// recogniser's layout), used within it.
class StageQuery {
 public:
  explicit StageQuery(const PlaceRecognizer& recognizer)
      : layout_(recognizer.layout()),
        options_(recognizer.options()),
        decider_(options_.method, options_.method_options) {
    decider_.OnLayoutChanged(*layout_);
  }
  // The joint representation of `sets`, if the method needs one and they make one.
  void BuildJoint(const ReferenceSets& sets) {
    if (const std::optional<JointKind> kind =
            decider_.method().JointNeeded(options_.method_options)) {
      std::vector<const StoredReferenceSet*> all;
      for (const StoredReferenceSet& s : sets.sets()) all.push_back(&s);
      try {
        CheckJointSets(all, sets.num_places());
      } catch (const std::invalid_argument&) {
        return;  // sets that make none (one set): the method fuses them alone, as the map
      }
      joint_ = std::make_unique<JointRepresentation>(
          JointRepresentation::Build(*kind, all, sets.num_places(), options_.method_options.joint));
    }
  }
  Recognition Decide(DistanceStage& stage, const ReferenceSets& sets, const RowMatrixXf& row) {
    QueryDistances d =
        QueryDistances::AllPresent(stage.Distances(DistanceMetric::kEuclidean, row, sets));
    if (joint_) d.SetJoint({joint_->kind(), 1, joint_->Distances(row)});
    return decider_.Decide(*layout_, d, false);
  }
  PlaceDecider& decider() { return decider_; }
  const PlaceLayout& layout() const { return *layout_; }

 private:
  MapBackend::Layout layout_;
  RecognizerOptions options_;
  PlaceDecider decider_;
  std::unique_ptr<JointRepresentation> joint_;
};

// Resident memory of this process, bytes (VmRSS).
inline size_t ResidentBytes() {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stoul(line.substr(6)) * 1024;
  }
  return 0;
}

// Of the resident bytes, the process's own (RssAnon: its heap and stacks), apart from the
// pages of mapped files (RssFile: the page cache's, which the kernel may drop and read
// again), 0 if unknown.
inline size_t AnonymousResidentBytes() {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("RssAnon:", 0) == 0) return std::stoul(line.substr(8)) * 1024;
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
