#include "src/tools/benchmark/benchmark_fusion.h"

#include <cstdio>
#include <random>
#include <vector>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/methods.h"
#include "src/tools/benchmark/benchmark_util.h"
#include "src/tools/benchmark/naive_bsf.h"

namespace bsf_vpr {
namespace tools {

void BenchmarkFusion(int repeats, int scale) {
  const int n = 3000 / scale, m = 3;
  std::vector<std::vector<float>> d(m);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<float> uni(0.5f, 2.0f);
  for (auto& v : d) {
    v.resize(static_cast<size_t>(n));
    for (float& x : v) x = uni(rng);
  }
  std::vector<SetDistances> views;
  for (const auto& v : d) views.push_back({v.data(), nullptr, n});
  MethodOptions o;
  o.likelihood.variant = LikelihoodVariant::kTwoSided;  // exactly the paper, as the baseline
  o.fusion = FusionRule::kProduct;
  const Method bsf = ParseMethod("bsf", {"a", "b", "c"});
  int ours_match = -1, naive_match = -2;
  std::vector<double> post;
  // A fraction of a millisecond: each timed run repeats it 50 times (per-call time reported).
  constexpr int kCalls = 50;
  const double ours = TimeMs(repeats,
                             [&] {
                               for (int c = 0; c < kCalls; ++c)
                                 ours_match = RunMethod(bsf, views, n, o).match;
                             }) /
                      kCalls;
  const double naive = TimeMs(repeats, [&] { naive_match = tools::NaiveBsf(d, 0.04, &post); });
  std::printf(
      "fusion  M=%d N=%d: bsf_vpr %.3f ms, straightforward O(N^2) %.1f ms: %.0fx faster%s\n", m, n,
      ours, naive, naive / ours, ours_match == naive_match ? "" : " (MATCHES DIFFER)");
  // The default fusion (adaptive) and the mixture on the same distances: their cost beside
  // the paper's product, the three timed in turn (the ratios are medians over the rounds).
  // Each runs as in a stream (a MethodRunner keeping its state), the queries alternating
  // between two scenes, so that the adaptive fusion counts each in its places' means and
  // corrects by them as it does on a drive.
  MethodOptions mixture;
  mixture.likelihood.variant = LikelihoodVariant::kTwoSided;  // only the fusion differs
  mixture.fusion = FusionRule::kMixture;
  MethodOptions adaptive = mixture;
  adaptive.fusion = FusionRule::kAdaptive;
  // Two scenes: the distances as drawn, and the same reversed (another profile).
  const auto two_scenes = [](const std::vector<std::vector<float>>& drawn,
                             std::vector<std::vector<float>>* reversed) {
    *reversed = drawn;
    for (auto& v : *reversed) std::reverse(v.begin(), v.end());
    std::vector<std::vector<SetDistances>> scenes(2);
    for (size_t u = 0; u < drawn.size(); ++u) {
      const int count = static_cast<int>(drawn[u].size());
      scenes[0].push_back({drawn[u].data(), nullptr, count});
      scenes[1].push_back({(*reversed)[u].data(), nullptr, count});
    }
    return scenes;
  };
  const auto fusion_times = [&](const Method& method,
                                const std::vector<std::vector<SetDistances>>& scenes, int places,
                                int calls, const std::vector<MethodOptions>& rules) {
    std::vector<MethodRunner> runners;
    for (const MethodOptions& options : rules) runners.emplace_back(method, options);
    std::vector<size_t> next(runners.size(), 0);
    // Untimed, a stream long enough for the places' means to be in use.
    for (MethodRunner& runner : runners) {
      for (int c = 0; c < AdaptiveFusion::kPlaceMeansLag + 2; ++c) {
        runner.Step(scenes[static_cast<size_t>(c) % scenes.size()], places, nullptr,
                    std::nullopt, true);
      }
    }
    std::vector<std::function<void()>> fns;
    for (size_t k = 0; k < runners.size(); ++k) {
      fns.push_back([&runners, &next, &scenes, k, places, calls] {
        for (int c = 0; c < calls; ++c) {
          runners[k].Step(scenes[next[k]++ % scenes.size()], places, nullptr, std::nullopt, true);
        }
      });
    }
    std::vector<std::vector<double>> ms = InterleavedTimesMs(repeats, fns);
    for (std::vector<double>& t : ms) {
      for (double& v : t) v /= calls;
    }
    return ms;
  };
  std::vector<std::vector<float>> d_reversed;
  const std::vector<std::vector<double>> small =
      fusion_times(bsf, two_scenes(d, &d_reversed), n, kCalls, {o, adaptive, mixture});
  std::printf(
      "fusion  M=%d N=%d, timed in turn: default (adaptive) %.3f ms, %.2fx the paper's product "
      "(%.3f ms); mixture %.3f ms, %.2fx\n",
      m, n, Median(small[1]), MedianRatio(small[1], small[0]), Median(small[0]), Median(small[2]),
      MedianRatio(small[2], small[0]));
  // A large map: M = 10 sets of one descriptor at N = 100,000 places.
  const int big_n = 100000 / scale, big_m = 10;
  std::vector<std::vector<float>> big(big_m);
  for (auto& v : big) {
    v.resize(static_cast<size_t>(big_n));
    for (float& x : v) x = uni(rng);
  }
  const Method big_bsf =
      ParseMethod("bsf", {"s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7", "s8", "s9"});
  std::vector<std::vector<float>> big_reversed;
  const std::vector<std::vector<double>> large =
      fusion_times(big_bsf, two_scenes(big, &big_reversed), big_n, 1, {adaptive, mixture});
  std::printf(
      "fusion  M=%d N=%d, timed in turn: default (adaptive) %.2f ms, mixture %.2f ms: %.2fx\n",
      big_m, big_n, Median(large[0]), Median(large[1]), MedianRatio(large[0], large[1]));
}

}  // namespace tools
}  // namespace bsf_vpr
