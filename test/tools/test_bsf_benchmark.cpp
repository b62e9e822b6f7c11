// Smoke test of bsf_benchmark, built with the benchmark part (when FAISS and OpenBLAS are
// found): every section runs on tiny shapes; no timing is asserted.
#include <gtest/gtest.h>

#include <string>

#include "tool_test_util.h"

namespace bsf_vpr {
namespace {

using testing::Result;
using testing::RunCommand;

TEST(BenchmarkTool, RunsEverySectionAndReportsRatios) {
  const Result r = RunCommand(std::string(BSF_BENCHMARK_PATH) + " --quick --repeats 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* fragment :
       {"fusion  M=3 N=300", "faster", "the memory limit", "FAISS's time", "of the GEMM throughput",
        "scaling     1000", "int8", "float32's time"}) {
    EXPECT_NE(r.output.find(fragment), std::string::npos) << fragment << "\n" << r.output;
  }
  EXPECT_EQ(r.output.find("MATCHES DIFFER"), std::string::npos) << r.output;
  EXPECT_EQ(RunCommand(std::string(BSF_BENCHMARK_PATH) + " --sections warp").exit_code, 2);
  const Result int8 = RunCommand(std::string(BSF_BENCHMARK_PATH) +
                                 " --quick --repeats 1 --sections scaling --storage int8");
  ASSERT_EQ(int8.exit_code, 0) << int8.output;
  EXPECT_NE(int8.output.find("scaling (int8 storage)"), std::string::npos) << int8.output;
}

}  // namespace
}  // namespace bsf_vpr
