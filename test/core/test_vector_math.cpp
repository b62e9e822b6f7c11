#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "src/core/internal/vector_math.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

// Units in the last place between a and b (both finite, same sign or zero).
double UlpDistance(double a, double b) {
  if (a == b) return 0;
  const double ulp = std::nextafter(std::abs(b), INFINITY) - std::abs(b);
  return std::abs(a - b) / ulp;
}

// The first of the 20000 inputs in [-40, 1] (after the 25 special ones and the wide ones).
constexpr size_t kNear = 25 + 20000;

std::vector<double> ExpInputs() {
  std::vector<double> x = {0.0,    -0.0,    1e-300,   -1e-300,  1.0,    -1.0,    0.5,
                           -0.5,   0.34657, -0.34657, 700.0,    709.78, 709.79,  800.0,
                           -700.0, -708.4,  -708.39,  -720.0,   -745.0, -745.14, -800.0,
                           -1e308, 1e308,   INFINITY, -INFINITY};
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> wide(-760.0, 720.0), near(-40.0, 1.0);
  for (int k = 0; k < 20000; ++k) x.push_back(wide(rng));
  for (int k = 0; k < 20000; ++k) x.push_back(near(rng));
  for (int k = 0; k < 400; ++k) x.push_back(std::ldexp(1.0, -k / 4));  // small arguments
  x.push_back(std::numeric_limits<double>::quiet_NaN());
  x.push_back(3.0);  // an odd count: every kernel's tail runs
  return x;
}

TEST(VectorMath, ExpIsWithinTwoUlpOfTheLibraryAndExactAtTheEnds) {
  const std::vector<double> x = ExpInputs();
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    std::vector<double> y(x.size());
    kernels::Exp(x.data(), static_cast<Eigen::Index>(x.size()), 0.0, y.data());
    for (size_t k = 0; k < x.size(); ++k) {
      const double expected = std::exp(x[k]);
      if (std::isnan(x[k])) {
        EXPECT_TRUE(std::isnan(y[k])) << kernel;
      } else if (expected == 0 || std::isinf(expected) || x[k] > 709.78 || x[k] < -745.13) {
        EXPECT_EQ(y[k], expected) << kernel << " exp(" << x[k] << ")";
      } else if (expected < std::numeric_limits<double>::min()) {
        // Subnormal results: within one subnormal step and a half of the exact value.
        EXPECT_LE(std::abs(y[k] - expected), 1.5 * std::numeric_limits<double>::denorm_min())
            << kernel << " exp(" << x[k] << ")";
      } else {
        ASSERT_LE(UlpDistance(y[k], expected), 2.0) << kernel << " exp(" << x[k] << ")";
      }
    }
  }
  SetDistanceKernel("auto");
}

std::vector<double> LogInputs() {
  std::vector<double> x = {1.0,
                           2.0,
                           0.5,
                           0.70710678118654752,
                           0.70710678118654746,
                           1.41421356237309492,
                           1.41421356237309515,
                           1e-300,
                           1e300,
                           0.0,
                           -0.0,
                           -1.0,
                           INFINITY,
                           -INFINITY,
                           std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::min(),
                           std::numeric_limits<double>::denorm_min(),
                           3e-310,
                           std::numeric_limits<double>::max(),
                           1.0 + 1e-15,
                           1.0 - 1e-16};
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> exponent(-1074.0, 1023.0), near(0.5, 2.0);
  for (int k = 0; k < 20000; ++k) x.push_back(std::exp2(exponent(rng)));
  for (int k = 0; k < 20000; ++k) x.push_back(near(rng));
  x.push_back(7.0);  // an odd count
  return x;
}

TEST(VectorMath, LogIsWithinTwoUlpOfTheLibraryAndExactAtTheEnds) {
  const std::vector<double> x = LogInputs();
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    std::vector<double> y(x.size());
    kernels::Log(x.data(), static_cast<Eigen::Index>(x.size()), y.data());
    for (size_t k = 0; k < x.size(); ++k) {
      const double expected = std::log(x[k]);
      if (std::isnan(expected)) {
        EXPECT_TRUE(std::isnan(y[k])) << kernel << " log(" << x[k] << ")";
      } else if (std::isinf(expected) || expected == 0) {
        EXPECT_EQ(y[k], expected) << kernel << " log(" << x[k] << ")";
      } else {
        ASSERT_LE(UlpDistance(y[k], expected), 2.0) << kernel << " log(" << x[k] << ")";
      }
    }
  }
  SetDistanceKernel("auto");
}

TEST(VectorMath, EveryKernelGivesTheSameBitsForLog) {
  const std::vector<double> x = LogInputs();
  std::vector<double> first;
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    std::vector<double> y = x;
    kernels::Log(y.data(), static_cast<Eigen::Index>(y.size()), y.data());  // in place
    if (first.empty()) {
      first = y;
      continue;
    }
    ASSERT_EQ(std::memcmp(y.data(), first.data(), y.size() * sizeof(double)), 0) << kernel;
  }
  SetDistanceKernel("auto");
  EXPECT_EQ(LogOf(Eigen::ArrayXd::Constant(3, 1.0))(1), 0.0);
}

TEST(VectorMath, EveryKernelGivesTheSameBitsForExpAndItsSum) {
  const std::vector<double> x = ExpInputs();
  std::vector<double> shifted(x.begin(), x.begin() + 9001);  // not a multiple of 8
  std::vector<double> first;
  double first_sum = 0;
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    std::vector<double> y(x.size());
    kernels::Exp(x.data(), static_cast<Eigen::Index>(x.size()), 0.0, y.data());
    // In place, with a shift, and the sum the normalisations use.
    std::vector<double> z = shifted;
    kernels::Exp(z.data(), static_cast<Eigen::Index>(z.size()), -2.5, z.data());
    y.insert(y.end(), z.begin(), z.end());
    const double sum = kernels::SumExp(x.data() + kNear, 19999, 3.0);
    std::vector<double> written(19999);  // Exp returns the same sum of what it writes
    EXPECT_EQ(kernels::Exp(x.data() + kNear, 19999, 3.0, written.data()), sum) << kernel;
    if (first.empty()) {
      first = y;
      first_sum = sum;
      continue;
    }
    ASSERT_EQ(std::memcmp(y.data(), first.data(), y.size() * sizeof(double)), 0) << kernel;
    EXPECT_EQ(sum, first_sum) << kernel;
  }
  SetDistanceKernel("auto");
  double exact = 0;
  for (int k = 0; k < 19999; ++k) exact += std::exp(x[kNear + k] - 3.0);
  EXPECT_NEAR(first_sum, exact, 1e-12 * exact);
  EXPECT_EQ(ExpOf(Eigen::ArrayXd::Constant(3, 2.0), 2.0)(2), 1.0);
}

// The filter's step sums as the shifts they are: moved += w[k] * p shifted by s_lo + k, in k
// order. Every kernel must give exactly these bits.
std::vector<double> ShiftedSums(const std::vector<double>& p, const std::vector<double>& w,
                                long s_lo) {
  const long n = static_cast<long>(p.size());
  std::vector<double> moved(p.size(), 0.0);
  for (size_t k = 0; k < w.size(); ++k) {
    const long s = s_lo + static_cast<long>(k);
    for (long j = 0; j < n; ++j) {
      if (j - s >= 0 && j - s < n)
        moved[static_cast<size_t>(j)] += w[k] * p[static_cast<size_t>(j - s)];
    }
  }
  return moved;
}

TEST(VectorMath, StepSumsAreTheShiftedSumsOnEveryKernel) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    for (const long n : {0L, 1L, 5L, 100L, 1003L}) {
      for (const int taps : {1, 9, 17}) {
        for (const long s_lo : {-2000L, -20L, -3L, 0L, 1L, 7L, 1002L, 5000L}) {
          std::vector<double> p(static_cast<size_t>(n)), w(static_cast<size_t>(taps));
          for (double& v : p) v = uni(rng);
          for (double& v : w) v = uni(rng);
          std::vector<double> moved(p.size(), -1.0);
          const double total = kernels::StepSums(p.data(), n, w.data(), taps, s_lo, moved.data());
          const std::vector<double> expected = ShiftedSums(p, w, s_lo);
          double lanes[8] = {};  // the fixed order of the sum
          for (size_t j = 0; j < expected.size(); ++j) lanes[j % 8] += expected[j];
          const double expected_total = ((lanes[0] + lanes[4]) + (lanes[1] + lanes[5])) +
                                        ((lanes[2] + lanes[6]) + (lanes[3] + lanes[7]));
          ASSERT_EQ(total, expected_total)
              << kernel << " n " << n << " taps " << taps << " s_lo " << s_lo;
          ASSERT_TRUE(moved.empty() ||  // (memcmp of no bytes still wants pointers)
                      std::memcmp(moved.data(), expected.data(), moved.size() * sizeof(double)) ==
                          0)
              << kernel << " n " << n << " taps " << taps << " s_lo " << s_lo;
        }
      }
    }
  }
  SetDistanceKernel("auto");
}

// The adaptive fusion's prior times a likelihood: on every kernel, bit for bit the scalar
// loop (x = (a x + b) l, each operation rounded in that order) and its sum in the eight lanes
// (lane k mod 8, the lanes added in the fixed tree), with and without a tail.
TEST(VectorMath, ScaleShiftMultiplyIsTheScalarLoopOnEveryKernel) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::uniform_real_distribution<double> exponent(-300.0, 300.0);
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    for (const Eigen::Index n : {0, 1, 7, 8, 9, 12, 100, 1003}) {
      for (int draw = 0; draw < 4; ++draw) {
        std::vector<double> x(static_cast<size_t>(n)), l(x.size());
        for (size_t k = 0; k < x.size(); ++k) {
          x[k] = uni(rng);
          l[k] = uni(rng) * std::pow(10.0, exponent(rng) / 10);
        }
        const double a = uni(rng) / 3.0, b = uni(rng) * 1e-3;
        std::vector<double> expected = x;
        double lanes[8] = {};
        for (size_t k = 0; k < expected.size(); ++k) {
          const double scaled = a * expected[k];
          const double shifted = scaled + b;
          expected[k] = shifted * l[k];
          lanes[k % 8] += expected[k];
        }
        const double want = ((lanes[0] + lanes[4]) + (lanes[1] + lanes[5])) +
                            ((lanes[2] + lanes[6]) + (lanes[3] + lanes[7]));
        const double got = kernels::ScaleShiftMultiply(x.data(), n, a, b, l.data());
        const std::string at = kernel + " n " + std::to_string(n) + " draw " + std::to_string(draw);
        ASSERT_EQ(std::memcmp(&got, &want, sizeof(double)), 0) << at;
        ASSERT_TRUE(n == 0 ||
                    std::memcmp(x.data(), expected.data(), x.size() * sizeof(double)) == 0)
            << at;
      }
    }
  }
  SetDistanceKernel("auto");
}

// The fusion's weighted sums of columns: on every kernel, bit for bit what Eigen's y += a * x
// gives one column after another, for lengths with and without a tail and any number of
// columns (none included), with weights and values over many orders of magnitude.
TEST(VectorMath, AddScaledIsEigensColumnByColumnSumOnEveryKernel) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> exponent(-300.0, 300.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    for (const Eigen::Index n : {0, 1, 7, 8, 9, 100, 1003}) {
      for (const int m : {0, 1, 3, 10}) {
        std::vector<Eigen::ArrayXd> x(static_cast<size_t>(m), Eigen::ArrayXd(n));
        std::vector<const double*> columns;
        std::vector<double> a;
        for (Eigen::ArrayXd& col : x) {
          for (Eigen::Index k = 0; k < n; ++k)
            col[k] = uni(rng) * std::pow(10.0, exponent(rng) / 10);
          columns.push_back(col.data());
          a.push_back(uni(rng) * 4.0 - 1.0);
        }
        Eigen::ArrayXd y(n), expected(n);
        for (Eigen::Index k = 0; k < n; ++k) y[k] = expected[k] = uni(rng) - 0.5;
        for (int j = 0; j < m; ++j)
          expected += a[static_cast<size_t>(j)] * x[static_cast<size_t>(j)];
        kernels::AddScaled(y.data(), columns.data(), a.data(), m, n);
        ASSERT_TRUE(n == 0 || std::memcmp(y.data(), expected.data(), n * sizeof(double)) == 0)
            << kernel << " n " << n << " m " << m;
      }
    }
  }
  SetDistanceKernel("auto");
}

// The eight-lane sums behind the selection's and the fusion's mean and deviation: on every
// kernel, bit for bit the scalar loops (lane j adds k = j mod 8, the tail to lanes 0, 1, ...),
// the minimum's lanes with NaN and signed zeros as std::min keeps them.
TEST(VectorMath, LaneSumsAreTheScalarLoopsOnEveryKernel) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> uni(0.0f, 2.0f);
  const auto tree = [](const double* l) {
    return ((l[0] + l[4]) + (l[1] + l[5])) + ((l[2] + l[6]) + (l[3] + l[7]));
  };
  for (const std::string& kernel : testing::AvailableKernels()) {
    SetDistanceKernel(kernel);
    for (const int n : {1, 7, 8, 9, 16, 100, 1003, 4099}) {
      for (const int draw : {0, 1, 2, 3, 4, 5, 6, 7}) {  // many draws: a rounding shows in some
        const bool odd = draw == 0;
        std::vector<float> v(static_cast<size_t>(n)), c(v.size());
        for (float& x : v) x = uni(rng) * 1e3f;
        for (float& x : c) x = uni(rng);
        if (odd) {  // NaN, signed zeros and a repeated minimum
          v[0] = -0.0f;
          if (n > 3) v[3] = 0.0f;
          if (n > 9) v[9] = std::numeric_limits<float>::quiet_NaN();
          if (n > 12) v[12] = -0.0f;
        }
        double sum[8] = {}, diff[8] = {}, ss[8] = {};
        float low[8], expected_low[8];
        std::fill(low, low + 8, v[0]);
        std::fill(expected_low, expected_low + 8, v[0]);
        std::vector<float> out(v.size()), expected_out(v.size());
        const int full = n - n % 8;
        for (int k = 0; k < n; ++k) {
          const int j = k < full ? k % 8 : k - full;
          sum[j] += v[static_cast<size_t>(k)];
          expected_low[j] = std::min(expected_low[j], v[static_cast<size_t>(k)]);
          expected_out[static_cast<size_t>(k)] =
              v[static_cast<size_t>(k)] - c[static_cast<size_t>(k)];
          diff[j] += expected_out[static_cast<size_t>(k)];
        }
        const double mean = tree(sum) / n;
        for (int k = 0; k < n; ++k) {
          const double e = v[static_cast<size_t>(k)] - mean;
          ss[k < full ? k % 8 : k - full] += e * e;
        }
        const double got_sum = kernels::LaneSum(v.data(), n, low);
        const double got_diff = kernels::LaneDifferenceSum(v.data(), c.data(), n, out.data());
        const double got_ss = kernels::LaneSquaredDeviations(v.data(), n, mean);
        const double want_sum = tree(sum), want_diff = tree(diff), want_ss = tree(ss);
        const std::string at = kernel + " n " + std::to_string(n) + " draw " + std::to_string(draw);
        ASSERT_EQ(std::memcmp(&got_sum, &want_sum, sizeof(double)), 0) << at;
        ASSERT_EQ(std::memcmp(&got_diff, &want_diff, sizeof(double)), 0) << at;
        ASSERT_EQ(std::memcmp(&got_ss, &want_ss, sizeof(double)), 0) << at;
        ASSERT_EQ(std::memcmp(low, expected_low, sizeof(low)), 0) << at;
        ASSERT_EQ(std::memcmp(out.data(), expected_out.data(), out.size() * sizeof(float)), 0)
            << at;
        const double alone = kernels::LaneSum(v.data(), n, nullptr);  // without the minimum
        EXPECT_EQ(std::memcmp(&alone, &got_sum, sizeof(double)), 0) << at;
      }
    }
  }
  SetDistanceKernel("auto");
}

}  // namespace
}  // namespace bsf_vpr
