#include "src/tools/benchmark/benchmark_off_map.h"

#include <cstdio>
#include <string>
#include <vector>

#include "bsf_vpr/map/place_recognizer.h"
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
  const PairedQueryTimes t = TimePairedQueries(with, without, repeats, m, n, d, 600, 19);
  std::printf(
      "offmap  M=%d N=%d D=%d float32, %s, timed in turn: a query with off_map (the default) "
      "%.2f ms, without it %.2f ms: %.3fx\n",
      m, n, d, method.c_str(), Median(t.a_ms), Median(t.b_ms), MedianRatio(t.a_ms, t.b_ms));
}

}  // namespace

void BenchmarkOffMap(int repeats, int scale) {
  for (const char* method : {"bsf", "bsf+filter"})
    QueryCost(method, repeats, 3, 3000 / scale, 4096);
}

}  // namespace tools
}  // namespace bsf_vpr
