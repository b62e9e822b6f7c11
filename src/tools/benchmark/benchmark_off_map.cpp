#include "src/tools/benchmark/benchmark_off_map.h"

#include <cstdio>
#include <string>
#include <vector>

#include "bsf_vpr/core/place_recognizer.h"
#include "src/tools/benchmark/benchmark_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

// A query of `method` with and without off_map, in a stream (a query of the default
// carries the filters of its hypotheses and of "off" from one query to the next).
void QueryCost(const std::string& method, int repeats, int m, int n, int d) {
  RecognizerOptions with;
  with.method = method;
  RecognizerOptions without = with;
  without.method_options.off_map.enabled = false;
  PlaceRecognizer a(with), b(without);
  for (int u = 0; u < m; ++u) {
    const RowMatrixXf rows = Uniform(n, d, 600 + u);
    a.AddReferenceSet(MakeReferenceSet("s" + std::to_string(u), rows));
    b.AddReferenceSet(MakeReferenceSet("s" + std::to_string(u), rows));
  }
  const RowMatrixXf queries = Uniform(32, d, 19);
  a.Recognize(queries.row(0).transpose(), true);  // the joint representation's build
  b.Recognize(queries.row(0).transpose(), true);
  constexpr int kCalls = 8;
  int next_a = 1, next_b = 1;
  const auto stream = [&](PlaceRecognizer* r, int* next) {
    return [r, next, &queries] {
      for (int c = 0; c < kCalls; ++c) {
        r->Recognize(queries.row((*next)++ % queries.rows()).transpose(), true);
      }
    };
  };
  std::vector<std::vector<double>> ms =
      InterleavedTimesMs(repeats, {stream(&a, &next_a), stream(&b, &next_b)});
  for (std::vector<double>& t : ms) {
    for (double& v : t) v /= kCalls;
  }
  std::printf(
      "offmap  M=%d N=%d D=%d float32, %s, timed in turn: a query with off_map (the default) "
      "%.2f ms, without it %.2f ms: %.3fx\n",
      m, n, d, method.c_str(), Median(ms[0]), Median(ms[1]), MedianRatio(ms[0], ms[1]));
}

}  // namespace

void BenchmarkOffMap(int repeats, int scale) {
  for (const char* method : {"bsf", "bsf+filter"})
    QueryCost(method, repeats, 3, 3000 / scale, 4096);
}

}  // namespace tools
}  // namespace bsf_vpr
