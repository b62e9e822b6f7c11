#include "src/tools/benchmark/benchmark_large.h"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "bsf_vpr/core/likelihood.h"
#include "bsf_vpr/core/selection.h"
#include "bsf_vpr/map/place_recognizer.h"
#include "src/tools/benchmark/benchmark_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

using Clock = std::chrono::steady_clock;

double ResidentMb() { return ResidentBytes() / 1e6; }

}  // namespace

void BenchmarkLarge(int repeats, int scale, const FirstStageOptions& first_stage) {
  const int m = 10, n = 100000 / scale, d = 4096;
  // int8 rows, plus one set at float32 while it is made and converted.
  const double needed = (static_cast<double>(m) + 4.0) * n * d;
  if (needed > 0.75 * AvailableBytes()) {
    std::printf(
        "large   M=%d N=%d D=%d int8: skipped (needs %.1f GB; %.1f GB is 3/4 of the "
        "memory available)\n",
        m, n, d, needed / 1e9, 0.75 * AvailableBytes() / 1e9);
    return;
  }
  PlaceRecognizer recognizer(RecognizerOptions(), StoragePrecision::kInt8);
  const double rss0 = ResidentMb();
  auto t0 = Clock::now();
  for (int u = 0; u < m; ++u) {
    recognizer.AddReferenceSet(MakeReferenceSet("s" + std::to_string(u), Uniform(n, d, 100 + u)));
  }
  const double build_s = MsSince(t0) / 1000;
  const double map_mb = ResidentMb() - rss0;
  const RowMatrixXf queries = Uniform(repeats + 1, d, 7);
  // Median time of Recognize over `repeats` queries, after one warm-up query.
  const auto time_queries = [&](PlaceRecognizer& r) {
    int q = 0;
    return TimeMs(repeats, [&] { r.Recognize(queries.row(q++).transpose(), false); });
  };
  const double exact_ms = time_queries(recognizer);

  // The first stage over the same sets (one recogniser holds them once): its index built
  // here, its distances decided as the recogniser decides them.
  StageQuery through(recognizer);
  recognizer.ReadSets([&](const ReferenceSets& sets) {
    through.BuildJoint(sets);
    DistanceStage stage;
    stage.SetOptions(first_stage);
    const double rss1 = ResidentMb();
    t0 = Clock::now();
    stage.Prepare(sets);
    const double index_s = MsSince(t0) / 1000;
    const double index_mb = ResidentMb() - rss1;
    int next = 0;
    const double pca_ms =
        TimeMs(repeats, [&] { through.Decide(stage, sets, queries.row(next++)); });
    const ApproximateIndex& index = *stage.index();
    // Where a query's time goes: the first stage's approximate distances, the re-ranking of
    // its candidates, and the decision on the distances (selection, likelihoods, fusion).
    // Of the decision, the likelihoods alone: each set's statistics and its likelihood
    // (PlaceMatchLogLikelihood: the rank counts and the Gaussian term over its 100,000
    // distances), the sets spread over the distance threads as the fusion spreads them.
    std::vector<double> stage_ms, approximate_ms, rerank_ms, decide_ms, likelihood_ms;
    std::vector<std::vector<double>> log_l(static_cast<size_t>(m));
    for (int q = 0; q < repeats; ++q) {
      const RowMatrixXf one = queries.row(q);
      const auto start = Clock::now();
      ApproximateIndex::StageTimes times;
      std::vector<RowMatrixXf> dist =
          index.Distances(DistanceMetric::kEuclidean, one, sets, &times);
      stage_ms.push_back(MsSince(start));
      approximate_ms.push_back(times.approximate_ms);
      rerank_ms.push_back(times.rerank_ms);
      const std::vector<RowMatrixXf> kept = dist;
      const auto decide = Clock::now();
      through.decider().Decide(through.layout(), QueryDistances::AllPresent(std::move(dist)),
                               false);
      decide_ms.push_back(MsSince(decide));
      const auto likelihoods = Clock::now();
      const int threads = m * n >= 50000 ? std::min(DistanceThreads(), m) : 1;  // as the fusion
      std::vector<std::thread> pool;
      for (int t = 0; t < threads; ++t) {
        pool.emplace_back([&, t] {
          for (int u = t; u < m; u += threads) {
            const RowMatrixXf& d = kept[static_cast<size_t>(u)];
            const SetDistances view{d.data(), nullptr, static_cast<int>(d.size())};
            std::vector<double>& out = log_l[static_cast<size_t>(u)];
            out.resize(d.size());
            PlaceMatchLogLikelihood(view, ComputeDistanceStats(view), LikelihoodOptions{},
                                    out.data());
          }
        });
      }
      for (std::thread& th : pool) th.join();
      likelihood_ms.push_back(MsSince(likelihoods));
    }
    std::printf(
        "large   M=%d N=%d D=%d int8 (%.0f MB resident, made in %.1f s; random data: time only): "
        "exact %.1f ms/query (%.1f queries/s) vs pca first stage (d'=%d, %d re-ranked per set; "
        "index %.1f s, %.0f MB) %.1f ms/query (%.1f queries/s; its distances %.1f ms): %.1fx "
        "faster\n",
        m, n, d, map_mb, build_s, exact_ms, 1000 / exact_ms, index.dimensions(),
        index.options().rerank, index_s, index_mb, pca_ms, 1000 / pca_ms, Median(stage_ms),
        exact_ms / pca_ms);
    std::printf(
        "large   time split of a pca query (medians): first stage %.1f ms, re-rank %.1f ms, "
        "decision (selection, likelihoods over %d distances, fusion; %s, fusion %s) %.1f ms; "
        "of the decision, the likelihoods alone (rank counts and Gaussian term, timed apart) "
        "%.1f ms\n",
        Median(approximate_ms), Median(rerank_ms), m * n, recognizer.options().method.c_str(),
        ToString(recognizer.options().method_options.fusion).c_str(), Median(decide_ms),
        Median(likelihood_ms));
  });
}

}  // namespace tools
}  // namespace bsf_vpr
