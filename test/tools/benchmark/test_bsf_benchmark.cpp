// Smoke test of bsf_benchmark, built with the benchmark part (when FAISS and OpenBLAS are
// found): every section runs on tiny shapes; no timing is asserted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "src/tools/benchmark/cpu_baseline.h"
#include "test/tools/tool_test_util.h"

namespace bsf_vpr {
namespace {

using testing::Result;
using testing::RunCommand;

TEST(BenchmarkTool, RunsEverySectionAndReportsRatios) {
  const Result r = RunCommand(std::string(BSF_BENCHMARK_PATH) + " --quick --repeats 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* fragment : {"machine ",
                               "vector extensions:",
                               "OpenBLAS kernel",
                               "fusion  M=3 N=300",
                               "default (adaptive)",
                               "faster",
                               "the memory limit",
                               "FAISS's time",
                               "of the GEMM throughput",
                               "scaling     1000",
                               "int8",
                               "float32's time",
                               "NumPy + OpenBLAS",
                               "cores busy",
                               "bsf_evaluate's phases: load",
                               "describe  10 images of 256x144",
                               "cv::imdecode",
                               "patchnorm_64x32_p8       input 64x32, D=2048",
                               "hog_64x32_c8_b9          input 64x32",
                               "onnx resnet50_light      input 224x224, D=1000",
                               "onnx squeezenet_light",
                               "x the resize",
                               "large   M=10 N=1000 D=4096 int8",
                               "vs pca first stage (d'=256",
                               "pca ms/query   speed-up",
                               "every distance first",
                               "the paper's method (bsf --fusion product",
                               "NumPy's distances alone",
                               "time split of a pca query",
                               "decision (selection, likelihoods over",
                               "a query of the default (with the discriminant)",
                               "discriminant built in",
                               "mean_descriptor built in",
                               "subspace built in",
                               "joint   M=10 N=10000 D=4096 int8: discriminant (64 dimensions",
                               "offmap  M=3 N=300 D=4096 float32, bsf, timed in turn",
                               "offmap  M=3 N=300 D=4096 float32, bsf+filter, timed in turn",
                               "mapped  open one set of 1000 x 4096 int8",
                               "memory-mapped, pca (d'=256",
                               "loaded while queries stream"}) {
    EXPECT_NE(r.output.find(fragment), std::string::npos) << fragment << "\n" << r.output;
  }
  EXPECT_EQ(r.output.find("MATCHES DIFFER"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("RESULTS DIFFER"), std::string::npos) << r.output;
  EXPECT_EQ(RunCommand(std::string(BSF_BENCHMARK_PATH) + " --sections warp").exit_code, 2);
  const Result no_images = RunCommand(std::string(BSF_BENCHMARK_PATH) +
                                      " --quick --sections describe --images /nonexistent");
  EXPECT_EQ(no_images.exit_code, 2) << no_images.output;
  EXPECT_NE(no_images.output.find("/nonexistent"), std::string::npos) << no_images.output;
  const Result int8 = RunCommand(std::string(BSF_BENCHMARK_PATH) +
                                 " --quick --repeats 1 --sections scaling --storage int8");
  ASSERT_EQ(int8.exit_code, 0) << int8.output;
  EXPECT_NE(int8.output.find("scaling (int8 storage;"), std::string::npos) << int8.output;
}

// The table row "bsf ..." of an evaluation's output, as numbers (empty if there is none).
std::vector<double> BsfRow(const std::string& out) {
  const size_t at = out.find("\nbsf ");
  if (at == std::string::npos) return {};
  std::stringstream in(out.substr(at + 4, out.find('\n', at + 1) - at - 4));
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

// query, match and confidence of each line of a matches file (its header skipped).
struct MatchRow {
  std::string query, match;
  double confidence = 0;
};
std::vector<MatchRow> Matches(const std::string& path) {
  std::ifstream in(path);
  std::vector<MatchRow> out;
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    MatchRow row;
    std::string confidence;
    std::getline(fields, row.query, ',');
    std::getline(fields, row.match, ',');
    std::getline(fields, confidence, ',');
    row.confidence = std::stod(confidence);
    out.push_back(row);
  }
  return out;
}

// The same match for every query, but where the two best places tie to float32's rounding:
// there the order of a sum decides, which differs between OpenBLAS's kernels (found on an
// Intel Xeon, family 6 model 167: Nordland-100 grey levels, query 80, places 55 and 54 at
// confidence -2.9329187 and -2.932909). Such ties are at most 1% of the queries.
void ExpectSameMatches(const std::vector<MatchRow>& a, const std::vector<MatchRow>& b,
                       const std::string& method) {
  ASSERT_EQ(a.size(), b.size()) << method;
  size_t ties = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].query, b[k].query) << method;
    if (a[k].match == b[k].match) continue;
    const double scale = std::max(1.0, std::abs(a[k].confidence));
    EXPECT_NEAR(a[k].confidence, b[k].confidence, 1e-5 * scale)
        << method << ": query " << a[k].query << " matched " << a[k].match << " and "
        << b[k].match << ", not a tie";
    ++ties;
  }
  EXPECT_LE(ties, a.size() / 100) << method << ": " << ties << " ties in " << a.size();
}

// bsf_evaluate --methods bsf --off-map false `method` and numpy_bsf `method` on `inputs` give
// the same table and the same match for every query; returns bsf_evaluate's row.
std::vector<double> ExpectNumPyGivesBsfEvaluatesResults(const std::string& inputs,
                                                        const std::string& method,
                                                        const std::string& dir) {
  // --off-map false: the belief over places only, which numpy_bsf computes (the off-map
  // hypothesis would change the confidence).
  const Result ours = RunCommand(std::string(BSF_EVALUATE_PATH) + inputs +
                                 " --methods bsf --off-map false --no-progress" + method +
                                 " --out " + dir + "/ours");
  EXPECT_EQ(ours.exit_code, 0) << ours.output;
  const Result numpy =
      RunCommand("PATH=/usr/bin:$PATH /usr/bin/python3 " + std::string(BSF_SOURCE_DIR) +
                 "/scripts/numpy_bsf" + inputs + method + " --out " + dir + "/numpy");
  EXPECT_EQ(numpy.exit_code, 0) << numpy.output;
  const std::vector<double> a = BsfRow(ours.output), b = BsfRow(numpy.output);
  EXPECT_EQ(a.size(), 6u) << ours.output;
  EXPECT_EQ(b.size(), 6u) << numpy.output;
  for (size_t k = 0; k < a.size() && k < b.size(); ++k)
    EXPECT_NEAR(a[k], b[k], 1e-9) << method << "\n" << ours.output << numpy.output;
  const std::vector<MatchRow> ma = Matches(dir + "/ours/matches/bsf.csv");
  EXPECT_GE(ma.size(), 100u) << method;
  ExpectSameMatches(ma, Matches(dir + "/numpy/matches/bsf.csv"), method);
  return a;
}

// The NumPy baseline is the same method: on real data (Gardens Point HDC-DELF, night
// against day, cosine, +-8 places) it gives bsf_evaluate's table, and the same matches, with
// the mixture of bsf_evaluate's defaults and with the paper's product and two-sided
// likelihood (relative selection, gamma 0.04); the paper's method also on two sets (the
// Nordland-100 64x32 summer and fall frames against winter as grey levels, Euclidean,
// +-2 places: real images, where gamma 0.04 selects both sets for 1 query of the 100 and
// gamma 0.2 for 16, so that the product of two sets' likelihoods is compared too).
TEST(BenchmarkTool, NumPyBaselineGivesBsfEvaluatesResultsOnRealData) {
  const std::string data = std::string(BSF_SOURCE_DIR) + "/data/gardens_point_hdc_delf/";
  const std::string inputs = " --reference day=" + data + "day_left.npy --query " + data +
                             "night_right.npy --tolerance 8 --distance cosine";
  const std::string dir = ::testing::TempDir() + "numpy_bsf_check";
  const std::vector<double> mixture =
      ExpectNumPyGivesBsfEvaluatesResults(inputs, " --fusion mixture", dir + "/mixture");
  ASSERT_EQ(mixture.size(), 6u);
  EXPECT_GT(mixture[2], 0.5) << "R@1 on Gardens Point";
  const std::string paper = " --fusion product --likelihood two_sided";
  const std::vector<double> product =
      ExpectNumPyGivesBsfEvaluatesResults(inputs, paper, dir + "/product");
  ASSERT_EQ(product.size(), 6u);
  EXPECT_GT(product[2], 0.5) << "R@1 on Gardens Point";

  // Nordland-100's frames as grey levels in [0, 1] (2048-d), one .npy per season.
  const std::string frames = std::string(BSF_SOURCE_DIR) + "/data/nordland_subset100/64x32/";
  const Result made = RunCommand(
      "PATH=/usr/bin:$PATH /usr/bin/python3 -c 'import numpy as np, os, sys; "
      "from PIL import Image; "
      "[np.save(sys.argv[2] + s + \".npy\", np.stack([np.asarray(Image.open("
      "os.path.join(sys.argv[1], s, f)).convert(\"L\"), dtype=np.float32).ravel() / 255 "
      "for f in sorted(os.listdir(os.path.join(sys.argv[1], s)))])) "
      "for s in (\"summer\", \"fall\", \"winter\")]' " +
      frames + " " + ::testing::TempDir() + "numpy_bsf_nordland_");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const std::string grey = ::testing::TempDir() + "numpy_bsf_nordland_";
  const std::vector<double> two = ExpectNumPyGivesBsfEvaluatesResults(
      " --reference summer=" + grey + "summer.npy --reference fall=" + grey + "fall.npy --query " +
          grey + "winter.npy --tolerance 2",
      paper, dir + "/nordland");
  ASSERT_EQ(two.size(), 6u);
  EXPECT_GT(two[2], 0.4) << "R@1 on Nordland-100, grey levels";
  ExpectNumPyGivesBsfEvaluatesResults(
      " --reference summer=" + grey + "summer.npy --reference fall=" + grey + "fall.npy --query " +
          grey + "winter.npy --tolerance 2 --gamma-fraction 0.2",
      paper, dir + "/nordland_gamma");
}

// The fair OpenBLAS: the kernel that fits a CPU's vector width, and which of OpenBLAS's own
// kernels already do (Prescott, SSE3, fits nothing wider; Zen and Haswell fit AVX2).
TEST(BenchmarkTool, TheBaselinesOpenBlasKernelFitsTheCpu) {
  tools::CpuInfo avx512;
  avx512.avx2 = avx512.avx512 = true;
  tools::CpuInfo avx2;
  avx2.avx2 = true;
  EXPECT_EQ(tools::FittingOpenBlasCore(avx512), "SkylakeX");
  EXPECT_EQ(tools::FittingOpenBlasCore(avx2), "Haswell");
  EXPECT_EQ(tools::FittingOpenBlasCore(tools::CpuInfo{}), "");
  EXPECT_FALSE(tools::CoreFits("Prescott", "SkylakeX"));
  EXPECT_FALSE(tools::CoreFits("Prescott", "Haswell"));
  EXPECT_FALSE(tools::CoreFits("Zen", "SkylakeX"));
  EXPECT_TRUE(tools::CoreFits("Zen", "Haswell"));
  EXPECT_TRUE(tools::CoreFits("SkylakeX", "SkylakeX"));
  EXPECT_TRUE(tools::CoreFits("COOPERLAKE", "SkylakeX"));
  // On this machine: the benchmark names the CPU and runs a kernel that fits it.
  const tools::CpuInfo cpu = tools::ReadCpuInfo();
  EXPECT_FALSE(cpu.model.empty());
  const Result r = RunCommand("env -u OPENBLAS_CORETYPE " + std::string(BSF_BENCHMARK_PATH) +
                              " --quick --repeats 1 --sections fusion");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string fitting = tools::FittingOpenBlasCore(cpu);
  if (!fitting.empty()) {
    const size_t at = r.output.find("OpenBLAS kernel ");
    ASSERT_NE(at, std::string::npos) << r.output;
    const std::string kernel = r.output.substr(at + 16, r.output.find(' ', at + 16) - at - 16);
    EXPECT_TRUE(tools::CoreFits(kernel, fitting)) << kernel << " for " << fitting << "\n"
                                                  << r.output;
  }
  // A kernel the caller sets is kept and said so.
  const Result set = RunCommand("OPENBLAS_CORETYPE=Haswell " + std::string(BSF_BENCHMARK_PATH) +
                                " --quick --repeats 1 --sections fusion");
  EXPECT_NE(set.output.find("OPENBLAS_CORETYPE=Haswell, set by the caller"), std::string::npos)
      << set.output;
  // and a caller's kernel narrower than the CPU is flagged, not silently compared with.
  const Result narrow = RunCommand("OPENBLAS_CORETYPE=Prescott " +
                                   std::string(BSF_BENCHMARK_PATH) +
                                   " --quick --repeats 1 --sections fusion");
  ASSERT_EQ(narrow.exit_code, 0) << narrow.output;
  EXPECT_NE(narrow.output.find("OPENBLAS_CORETYPE=Prescott, set by the caller"), std::string::npos)
      << narrow.output;
  EXPECT_EQ(narrow.output.find("NOT FAIR") != std::string::npos, !fitting.empty())
      << narrow.output;
  if (cpu.avx512) {
    EXPECT_NE(set.output.find("NOT FAIR: that kernel is narrower than this CPU's SkylakeX"),
              std::string::npos)
        << set.output;
  } else {
    EXPECT_EQ(set.output.find("NOT FAIR"), std::string::npos) << set.output;
  }
}

}  // namespace
}  // namespace bsf_vpr
