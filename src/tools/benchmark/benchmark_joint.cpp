#include "src/tools/benchmark/benchmark_joint.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/map/place_recognizer.h"
#include "src/tools/benchmark/benchmark_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

using Clock = std::chrono::steady_clock;

volatile int g_joint_sink;  // keeps the builds from being optimised away

double Seconds(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::vector<const StoredReferenceSet*> SetsOf(const ReferenceSets& map) {
  std::vector<const StoredReferenceSet*> out;
  for (const StoredReferenceSet& s : map.sets()) out.push_back(&s);
  return out;
}

// A query of the default bsf with and without its joint hypothesis, in a stream.
void QueryCost(int repeats, int m, int n, int d) {
  RecognizerOptions with;
  RecognizerOptions without = with;
  without.method_options.fusion_joint = FusionJoint::kNone;  // the sets alone
  // The first query of the default builds the discriminant (untimed in the rounds).
  const PairedQueryTimes t = TimePairedQueries(with, without, repeats, m, n, d, 300, 17);
  std::printf(
      "joint   M=%d N=%d D=%d float32, timed in turn: a query of the default (with the "
      "discriminant) %.2f ms, without it (fusion_joint none) %.2f ms: %.2fx (first query, "
      "with the build, %.2f s)\n",
      m, n, d, Median(t.a_ms), Median(t.b_ms), MedianRatio(t.a_ms, t.b_ms), t.a_first_s);
}

void BuildTimes(int repeats, int m, int n, int d) {
  ReferenceSets map;
  for (int u = 0; u < m; ++u)
    map.Add(MakeReferenceSet("s" + std::to_string(u), Uniform(n, d, 400 + u)));
  for (const JointKind kind :
       {JointKind::kDiscriminant, JointKind::kMeanDescriptor, JointKind::kSubspace}) {
    const double ms = TimeMs(repeats, [&] {
      const JointRepresentation j = JointRepresentation::Build(kind, SetsOf(map), n);
      g_joint_sink = j.num_places();
    });
    std::printf("joint   M=%d N=%d D=%d float32: %s built in %.2f s\n", m, n, d,
                ToString(kind).c_str(), ms / 1000);
  }
}

void LargeBuild(int m, int n, int d) {
  const double needed = (static_cast<double>(m) + 6.0) * n * d + 2.0 * n * d * 4;
  if (needed > 0.75 * AvailableBytes()) {
    std::printf(
        "joint   M=%d N=%d D=%d int8: skipped (needs %.1f GB; %.1f GB is 3/4 of the "
        "memory available)\n",
        m, n, d, needed / 1e9, 0.75 * AvailableBytes() / 1e9);
    return;
  }
  ReferenceSets map;
  map.SetStoragePrecision(StoragePrecision::kInt8);
  for (int u = 0; u < m; ++u)
    map.Add(MakeReferenceSet("s" + std::to_string(u), Uniform(n, d, 500 + u)));
  const double rss0 = ResidentBytes() / 1e6;
  const auto t0 = Clock::now();
  const JointRepresentation j =
      JointRepresentation::Build(JointKind::kDiscriminant, SetsOf(map), n);
  const double seconds = Seconds(t0);
  std::printf(
      "joint   M=%d N=%d D=%d int8: discriminant (%d dimensions, scatters on %d places) built "
      "in %.1f s on the calling thread; resident %.0f MB before, %.0f MB after (the "
      "representation %.0f MB)\n",
      m, n, d, j.discriminant_dimensions(), std::min(n, kJointScatterPlaces), seconds, rss0,
      ResidentBytes() / 1e6, j.MemoryBytes() / 1e6);
}

}  // namespace

void BenchmarkJoint(int repeats, int scale) {
  QueryCost(repeats, 3, 3000 / scale, 4096);
  BuildTimes(std::min(repeats, 3), 3, 3000 / scale, 4096);
  LargeBuild(10, 100000 / scale, 4096);
}

}  // namespace tools
}  // namespace bsf_vpr
