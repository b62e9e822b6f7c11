// Helpers shared by the core tests: seeded random data and the paper's formulas written
// the slow, obvious way, as oracles.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/types.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"
#include "bsf_vpr/evaluation/synthetic.h"
#include "src/core/internal/distance_kernels.h"

namespace bsf_vpr {
namespace testing {

// Every kernel compiled in that this CPU runs (simd_targets.h: AVX-512 VNNI, AVX-512, AVX2 or
// NEON, and the portable one always), best first; the first call prints them, so that a test
// log says which kernels the bit tests compared.
inline std::vector<std::string> AvailableKernels() {
  const std::vector<std::string> out = kernels::Available();
  static const bool printed = [&out] {
    std::string names;
    for (const std::string& k : out) names += " " + k;
    std::printf("distance kernels run by the tests:%s (auto: %s)\n", names.c_str(),
                DistanceKernel().c_str());
    return true;
  }();
  (void)printed;
  return out;
}

// Sets the global number of distance threads for a scope and restores the default (0: every
// core) when the scope ends, also when a failed assertion returns early.
class ScopedDistanceThreads {
 public:
  explicit ScopedDistanceThreads(int threads) { SetDistanceThreads(threads); }
  ~ScopedDistanceThreads() { SetDistanceThreads(0); }
  ScopedDistanceThreads(const ScopedDistanceThreads&) = delete;
  ScopedDistanceThreads& operator=(const ScopedDistanceThreads&) = delete;
  void Set(int threads) const { SetDistanceThreads(threads); }
};

// An .npy file from its header dictionary and data, as numpy.save writes it (version 1.0:
// the header padded with spaces so that the data starts at a multiple of 64 bytes).
inline std::string NpyFile(const std::string& dict, const std::string& data) {
  std::string h = dict;
  while ((10 + h.size() + 1) % 64) h.push_back(' ');
  h.push_back('\n');
  std::string out("\x93NUMPY\x01\x00", 8);
  out.push_back(static_cast<char>(h.size() & 0xff));
  out.push_back(static_cast<char>(h.size() >> 8));
  return out + h + data;
}

// A fixture with a fresh folder below /tmp for each test (removed after it), and helpers to
// write files into it.
class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/bsf_files_XXXXXX";
    const char* made = mkdtemp(tmpl);
    ASSERT_NE(made, nullptr) << "mkdtemp failed";
    dir_ = made;
  }
  void TearDown() override {
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  void WriteRaw(const std::string& name, const std::string& bytes) const {
    std::ofstream(Path(name), std::ios::binary) << bytes;
  }
  // An .npy with a hand-written header dictionary and `data_bytes` zero bytes of data.
  static std::string Npy(const std::string& dict, size_t data_bytes) {
    return NpyFile(dict, std::string(data_bytes, '\0'));
  }
  static std::string NpyWithData(const std::string& dict, const std::string& data) {
    return NpyFile(dict, data);
  }
  std::string dir_;
};

inline RowMatrixXf RandomMatrix(int rows, int cols, uint64_t seed, float scale = 1.0f) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> normal(0.0f, scale);
  RowMatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = normal(rng);
  return m;
}

inline std::vector<float> RandomDistances(int n, uint64_t seed, bool with_ties = false) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> uni(0.5f, 2.0f);
  std::vector<float> d(static_cast<size_t>(n));
  for (float& v : d) v = with_ties ? std::round(uni(rng) * 4.0f) / 4.0f : uni(rng);
  return d;
}

// Eq. placeMatch: sum_j 1{D_i <= D_j}, O(N^2).
inline int RankCountOracle(const std::vector<float>& d, size_t i) {
  int c = 0;
  for (float v : d) c += d[i] <= v ? 1 : 0;
  return c;
}

// log of Eq. obsLikelihoods with the Gaussian non-match term, up to a constant, O(N^2).
inline double LogLikelihoodOracle(const std::vector<float>& d, size_t i, bool one_sided) {
  double mean = 0;
  for (float v : d) mean += v;
  mean /= static_cast<double>(d.size());
  double var = 0;
  for (float v : d) var += (v - mean) * (v - mean);
  var /= static_cast<double>(d.size());
  double e = d[i] - mean;
  if (one_sided && e > 0) e = 0;
  const double log_gauss = var > 0 ? -0.5 * std::log(2 * M_PI * var) - e * e / (2 * var) : 0.0;
  return std::log(static_cast<double>(RankCountOracle(d, i))) - log_gauss;
}

// The evaluator's input for `data`'s queries against its map, from their exact euclidean
// distances (computed once into *all, which must outlive the input).
inline EvaluationInput ExactEvaluationInput(const SyntheticData& data,
                                            std::vector<RowMatrixXf>* all) {
  EvaluationInput in;
  in.num_queries = static_cast<int>(data.queries.rows());
  in.num_places = data.map.num_places();
  in.set_names = data.map.SetNames();
  *all = ComputeDistances(DistanceMetric::kEuclidean, data.queries, data.map);
  in.distances = [all](int b, int e, std::vector<RowMatrixXf>* block) {
    block->clear();
    for (const RowMatrixXf& d : *all) block->push_back(d.middleRows(b, e - b));
  };
  return in;
}

// A route of 400 places driven again under three conditions (image noise 0.5, 0.7, 0.9),
// each query under one of them at random (paper, Sec. V-D); query q is at place q.
inline SyntheticOptions RandomConditionRoute(int dimension, uint64_t seed) {
  SyntheticOptions opt;
  opt.num_places = 400;
  opt.dimension = dimension;
  opt.set_noise = {0.5, 0.7, 0.9};
  opt.query_noise = 0.5;
  opt.condition_strength = 1.5;
  opt.query_condition_weights = {1, 1, 1};
  opt.seed = seed;
  return opt;
}

}  // namespace testing
}  // namespace bsf_vpr
