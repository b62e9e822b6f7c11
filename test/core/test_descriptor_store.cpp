#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <tuple>

#include "bsf_vpr/core/distances.h"
#include "src/core/internal/distance_kernels.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

float FromBits(uint32_t bits) {
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

TEST(DescriptorStore, HalfConversionRoundTripsEveryHalfAndRoundsToNearestEven) {
  for (uint32_t h = 0; h < 0x10000u; ++h) {
    const uint16_t half = static_cast<uint16_t>(h);
    if ((half & 0x7c00u) == 0x7c00u && (half & 0x3ffu)) continue;  // NaN payloads
    ASSERT_EQ(FloatToHalf(HalfToFloat(half)), half) << std::hex << h;
    ASSERT_EQ(FloatToHalfOrInfinity(HalfToFloat(half)), half) << std::hex << h;
  }
  EXPECT_EQ(HalfToFloat(0x3c00u), 1.0f);
  EXPECT_EQ(HalfToFloat(0xc000u), -2.0f);
  EXPECT_EQ(HalfToFloat(0x7bffu), 65504.0f);
  EXPECT_EQ(HalfToFloat(0x0001u), std::ldexp(1.0f, -24));  // smallest subnormal
  // 1 + 2^-11 lies halfway between 1 and 1 + 2^-10: ties go to the even mantissa (1).
  EXPECT_EQ(FloatToHalf(1.0f + std::ldexp(1.0f, -11)), 0x3c00u);
  EXPECT_EQ(FloatToHalf(1.0f + 3 * std::ldexp(1.0f, -11)), 0x3c02u);  // tie -> even, upwards
  EXPECT_EQ(FloatToHalf(FromBits(0x3f800001u)), 0x3c00u);             // just above 1
  EXPECT_EQ(FloatToHalf(65519.0f), 0x7bffu);                          // still rounds to 65504
  EXPECT_EQ(FloatToHalf(std::ldexp(1.0f, -25)), 0x0000u);             // tie between 0 and 2^-24
  EXPECT_EQ(FloatToHalf(std::ldexp(1.5f, -25)), 0x0001u);
  EXPECT_THROW(FloatToHalf(65520.0f), std::invalid_argument);
  EXPECT_THROW(FloatToHalf(-1e6f), std::invalid_argument);
  // The .npy writer's variant: what rounds beyond 65504 becomes an infinity, as in NumPy.
  EXPECT_EQ(FloatToHalfOrInfinity(65519.0f), 0x7bffu);
  EXPECT_EQ(FloatToHalfOrInfinity(65520.0f), 0x7c00u);
  EXPECT_EQ(FloatToHalfOrInfinity(-1e6f), 0xfc00u);
  EXPECT_EQ(FloatToHalfOrInfinity(std::numeric_limits<float>::max()), 0x7c00u);
  EXPECT_EQ(FloatToHalf(-std::numeric_limits<float>::infinity()), 0xfc00u);
  EXPECT_EQ(FloatToHalf(std::numeric_limits<float>::quiet_NaN()) & 0x7e00u, 0x7e00u);
}

TEST(DescriptorStore, ReducedPrecisionCutsTheBytesAndReleasesTheFloat32Matrix) {
  const RowMatrixXf d = testing::RandomMatrix(100, 64, 1);
  for (StoragePrecision p :
       {StoragePrecision::kFloat32, StoragePrecision::kFloat16, StoragePrecision::kInt8}) {
    ReferenceSets map;
    map.SetStoragePrecision(p);
    map.Add(MakeReferenceSet("a", d));
    const StoredReferenceSet& set = map.set(0);
    EXPECT_EQ(set.size(), 100);
    EXPECT_EQ(set.dimension(), 64);
    EXPECT_EQ(set.precision(), p);
    const size_t descriptor_bytes = 100u * 64u * static_cast<size_t>(BytesPerElement(p));
    const size_t overhead = 100u * (sizeof(float) + sizeof(int));  // norms + place ids
    EXPECT_EQ(set.MemoryBytes(), descriptor_bytes + overhead) << ToString(p);
    EXPECT_EQ(set.data_bytes(), descriptor_bytes) << ToString(p);
    // Only a float32 set still has its float32 values to give back.
    if (p == StoragePrecision::kFloat32) {
      EXPECT_TRUE((set.ToReferenceSet().descriptors.array() == d.array()).all());
    } else {
      EXPECT_THROW(set.ToReferenceSet(), std::invalid_argument) << ToString(p);
    }
  }
  EXPECT_EQ(ParseStoragePrecision("int8"), StoragePrecision::kInt8);
  EXPECT_THROW(ParseStoragePrecision("int4"), std::invalid_argument);
  // A value float16 cannot hold is refused by name and leaves the map unchanged.
  ReferenceSets map;
  map.SetStoragePrecision(StoragePrecision::kFloat16);
  map.Add(MakeReferenceSet("a", d));
  const void* held = map.set(0).data();
  RowMatrixXf big = d;
  big(3, 5) = 1e6f;
  EXPECT_THROW(map.Add(MakeReferenceSet("big", big)), std::invalid_argument);
  EXPECT_EQ(map.num_sets(), 1);
  EXPECT_EQ(map.set(0).data(), held);
  EXPECT_EQ(map.num_places(), 100);
}

TEST(DescriptorStore, ReducedPrecisionDistancesStayCloseToFloat32) {
  const RowMatrixXf q = testing::RandomMatrix(5, 300, 2);
  const RowMatrixXf r = testing::RandomMatrix(40, 300, 3);
  for (DistanceMetric m : {DistanceMetric::kEuclidean, DistanceMetric::kCosine}) {
    const RowMatrixXf exact = ComputeDistances(m, q, MakeReferenceSet("a", r));
    for (auto [p, tolerance] : {std::pair{StoragePrecision::kFloat16, 1e-3f},
                                std::pair{StoragePrecision::kInt8, 2e-2f}}) {
      ReferenceSets map;
      map.SetStoragePrecision(p);
      map.Add(MakeReferenceSet("a", r));
      const RowMatrixXf reduced = ComputeDistances(m, q, map.set(0));
      const float scale = exact.cwiseAbs().maxCoeff();
      EXPECT_LT((reduced - exact).cwiseAbs().maxCoeff(), tolerance * scale)
          << ToString(p) << " " << ToString(m);
      EXPECT_GT((reduced - exact).cwiseAbs().maxCoeff(), 0.0f) << "not actually reduced";
    }
  }
}

// The SIMD kernels (AVX-512 VNNI, AVX-512, AVX2, NEON: all multiply-add with FMA) give the same
// distances, on batches that take every layout by default (19 and 20 queries: pairs on AVX-512
// and one query left over or none; 32 and more: lanes there, in panels of 12 queries (37, 36,
// 100) and 32 rows, whole and partial, elements past d in the last step), for any thread count
// and both metrics. Skipped on a CPU with one SIMD kernel: the layouts themselves are compared
// on every kernel below.
TEST(DescriptorStore, SimdKernelsGiveTheSameBits) {
  std::vector<std::string> simd = testing::AvailableKernels();
  simd.erase(std::find(simd.begin(), simd.end(), "portable"));
  if (simd.size() < 2) GTEST_SKIP() << "this CPU runs one SIMD kernel";
  for (auto [nq, d, rows] :
       {std::tuple{19, 8, 197}, std::tuple{20, 517, 197}, std::tuple{19, 1029, 197},
        std::tuple{20, 1029, 197}, std::tuple{16, 4096, 197}, std::tuple{37, 13, 197},
        std::tuple{37, 1029, 110}, std::tuple{40, 2051, 197}, std::tuple{40, 4096, 110},
        std::tuple{32, 5, 20}, std::tuple{36, 8, 65}, std::tuple{100, 1031, 70}}) {
    const RowMatrixXf q = testing::RandomMatrix(nq, d, 8);
    for (StoragePrecision p : {StoragePrecision::kFloat32, StoragePrecision::kFloat16}) {
      ReferenceSets map;
      map.SetStoragePrecision(p);
      map.Add(MakeReferenceSet("a", testing::RandomMatrix(rows, d, 9)));
      for (DistanceMetric m : {DistanceMetric::kEuclidean, DistanceMetric::kCosine}) {
        const testing::ScopedDistanceThreads threads(2);
        SetDistanceKernel(simd.back());
        const RowMatrixXf last = ComputeDistances(m, q, map.set(0));
        for (const std::string& kernel : simd) {
          SetDistanceKernel(kernel);
          const RowMatrixXf other = ComputeDistances(m, q, map.set(0));
          EXPECT_TRUE((other.array() == last.array()).all())
              << kernel << " vs " << simd.back() << ", " << nq << " queries, d=" << d << " "
              << ToString(m) << " " << ToString(p);
        }
      }
    }
  }
  SetDistanceKernel("auto");
}

// The pair and lane tiles (QueryLayout::kPairs, kLanes: chosen where they pay, AVX-512 and AVX2)
// give the row tiles' inner products bit for bit on every kernel this CPU runs, so that their
// algorithm is tested where AVX-512 is not at hand: float32 and float16 rows (pairs float32
// only; float16 falls back to rows), panels of queries whole and partial (19: pairs and one
// left over; 32, 37, 100), panels of rows whole, partial, of exactly 16 and under 16 (1, 16, 17,
// 33, 48, 70), rows shorter than a block, with a tail and in passes of 1024 (d = 1, 5, 8, 13,
// 1031, 2051), raw and made distances; and queries prepared by default on one kernel and run on
// another. Across the SIMD kernels the row tiles agree too (FMA everywhere).
TEST(DescriptorStore, PairAndLaneTilesGiveTheRowTilesBitsOnEveryKernel) {
  const std::vector<std::string> kernels = testing::AvailableKernels();
  for (const int d : {1, 5, 8, 13, 1031, 2051}) {
    const RowMatrixXf q = testing::RandomMatrix(100, d, 41);
    const RowMatrixXf rows = testing::RandomMatrix(70, d, 42);
    std::vector<uint16_t> halves(static_cast<size_t>(rows.size()));
    for (Eigen::Index k = 0; k < rows.size(); ++k) {
      halves[static_cast<size_t>(k)] = FloatToHalf(rows.data()[k]);
    }
    std::vector<float> q_norms(100), r_norms(70);
    for (int k = 0; k < 100; ++k) q_norms[k] = q.row(k).squaredNorm();
    for (int k = 0; k < 70; ++k) r_norms[k] = rows.row(k).squaredNorm();
    kernels::ToDistancesArgs finish;
    finish.query_squared_norms = q_norms.data();
    finish.row_squared_norms = r_norms.data();
    for (const StoragePrecision p : {StoragePrecision::kFloat32, StoragePrecision::kFloat16}) {
      kernels::RefRows refs;
      refs.precision = p;
      refs.data = p == StoragePrecision::kFloat32 ? static_cast<const void*>(rows.data())
                                                  : static_cast<const void*>(halves.data());
      refs.cols = d;
      for (const int nq : {19, 32, 37, 100}) {
        for (const int count : {1, 16, 17, 33, 48, 70}) {
          if (d > 1031 && count != 70) continue;  // the passes need no more shapes
          const auto dots = [&](const std::string& prepare_on, const std::string& run_on,
                                kernels::QueryLayout layout, bool distances) {
            SetDistanceKernel(prepare_on);
            const kernels::Queries prepared =
                kernels::PrepareQueries(q.data(), nq, d, d, false, layout);
            SetDistanceKernel(run_on);
            std::vector<float> out(static_cast<size_t>(nq) * count, -1.0f);
            kernels::Dots(refs, 0, count, prepared, out.data(), count,
                          distances ? &finish : nullptr);
            return out;
          };
          const std::string at = ToString(p) + " d=" + std::to_string(d) +
                                 " Q=" + std::to_string(nq) + " rows=" + std::to_string(count);
          std::vector<float> simd_rows;
          for (const std::string& kernel : kernels) {
            using kernels::QueryLayout;
            for (const bool distances : {false, true}) {
              const std::vector<float> by_rows =
                  dots(kernel, kernel, QueryLayout::kRows, distances);
              for (const QueryLayout layout : {QueryLayout::kPairs, QueryLayout::kLanes}) {
                const std::vector<float> other = dots(kernel, kernel, layout, distances);
                ASSERT_EQ(std::memcmp(other.data(), by_rows.data(), by_rows.size() * 4), 0)
                    << at << " on " << kernel << ", layout " << static_cast<int>(layout)
                    << (distances ? ", distances" : "");
              }
              if (distances || kernel == "portable") continue;
              if (simd_rows.empty()) simd_rows = by_rows;
              ASSERT_EQ(std::memcmp(simd_rows.data(), by_rows.data(), by_rows.size() * 4), 0)
                  << at << " on " << kernel << " vs " << kernels.front();
              for (const std::string& prepare_on : kernels) {
                const std::vector<float> other =
                    dots(prepare_on, kernel, QueryLayout::kAuto, false);
                ASSERT_EQ(std::memcmp(other.data(), by_rows.data(), by_rows.size() * 4), 0)
                    << at << ", prepared on " << prepare_on << ", run on " << kernel;
              }
            }
          }
        }
      }
    }
  }
  SetDistanceKernel("auto");
}

// Every kernel (the SIMD ones the CPU runs, and the portable one), every storage and
// every tile shape: a query alone gets bitwise what it gets in a batch, for any thread count.
TEST(DescriptorStore, EveryKernelAndStorageIsBitwiseTheSameAloneAndInABatch) {
  const std::vector<std::string> kernels = testing::AvailableKernels();
  // 11 queries: one AVX-512 tile of 8, a pair and one left over (2 AVX2 tiles of 4 and 3).
  // 1029: a pass of 1024 and a padded tail. 100 rows: two blocks, tiles and rows left over.
  const RowMatrixXf q = testing::RandomMatrix(11, 1029, 4);
  const RowMatrixXf r = testing::RandomMatrix(100, 1029, 5);
  for (const std::string& kernel : kernels) {
    SetDistanceKernel(kernel);
    EXPECT_EQ(DistanceKernel(), kernel);
    for (StoragePrecision p :
         {StoragePrecision::kFloat32, StoragePrecision::kFloat16, StoragePrecision::kInt8}) {
      ReferenceSets map;
      map.SetStoragePrecision(p);
      map.Add(MakeReferenceSet("a", r));
      const testing::ScopedDistanceThreads threads(1);
      const RowMatrixXf batch = ComputeDistances(DistanceMetric::kEuclidean, q, map.set(0));
      threads.Set(3);
      for (int i = 0; i < q.rows(); ++i) {
        const RowMatrixXf one =
            ComputeDistances(DistanceMetric::kEuclidean, RowMatrixXf(q.row(i)), map.set(0));
        ASSERT_TRUE((one.row(0).array() == batch.row(i).array()).all())
            << kernel << " " << ToString(p) << " query " << i;
      }
    }
  }
  SetDistanceKernel("auto");
  EXPECT_THROW(SetDistanceKernel("sse9"), std::invalid_argument);
}

// Every kernel name: the ones this CPU runs are taken and reported back, the others refused
// with std::invalid_argument (not compiled for this architecture, or not run by this CPU).
// With BSF_EXPECT_KERNEL set (scripts/cross_arm64: neon under qemu's Cortex-A72), the kernel
// chosen by CPU must be that one: an ARM build that fell back to the portable path fails here.
TEST(DescriptorStore, KernelsAreChosenByNameAndByCpu) {
  const std::vector<std::string> available = testing::AvailableKernels();
  for (const std::string name : {"avx512_vnni", "avx512", "avx2", "neon", "portable"}) {
    if (std::find(available.begin(), available.end(), name) != available.end()) {
      SetDistanceKernel(name);
      EXPECT_EQ(DistanceKernel(), name);
    } else {
      EXPECT_THROW(SetDistanceKernel(name), std::invalid_argument) << name;
    }
  }
  SetDistanceKernel("auto");
  EXPECT_EQ(DistanceKernel(), available.front());
  std::printf("distance kernel by CPU: %s\n", DistanceKernel().c_str());
  if (const char* expected = std::getenv("BSF_EXPECT_KERNEL")) {
    EXPECT_EQ(DistanceKernel(), expected) << "BSF_EXPECT_KERNEL";
  }
}

// int8 rows are summed exactly in integers: every kernel the CPU has (VNNI's 32 products an
// instruction, AVX-512's and AVX2's madd, NEON's widening multiply-adds, the portable loop) gives
// the same inner products, bit for bit, for every tile shape and row length (whole 32-element steps
// or a tail); the distances too on the vector kernels (the portable one rounds the query's float
// norm in another order).
TEST(DescriptorStore, Int8RowsGiveTheSameBitsOnEveryKernel) {
  const std::vector<std::string> kernels = testing::AvailableKernels();
  for (const int d : {8, 31, 32, 33, 256, 1029, 4096}) {
    const RowMatrixXf q = testing::RandomMatrix(40, d, 21);
    const RowMatrixXf rows = testing::RandomMatrix(100, d, 22);
    std::vector<int8_t> codes(static_cast<size_t>(rows.size()));
    for (Eigen::Index k = 0; k < rows.size(); ++k) {
      codes[static_cast<size_t>(k)] = static_cast<int8_t>(std::lround(rows.data()[k] * 127));
    }
    kernels::RefRows refs;
    refs.precision = StoragePrecision::kInt8;
    refs.data = codes.data();
    refs.cols = d;
    refs.scale = 1.0f / 127;
    ReferenceSets map;
    map.SetStoragePrecision(StoragePrecision::kInt8);
    map.Add(MakeReferenceSet("a", rows));
    std::vector<float> first;
    RowMatrixXf first_distances;
    for (const std::string& kernel : kernels) {
      SetDistanceKernel(kernel);
      for (int nq : {1, 11, 40}) {  // one query (tiles of 1 x 6) and batches (4 x 3)
        const kernels::Queries prepared = kernels::PrepareQueries(q.data(), nq, d, d, true);
        std::vector<float> dots(static_cast<size_t>(nq) * 100);
        kernels::Dots(refs, 0, 100, prepared, dots.data(), 100);
        if (first.size() < dots.size()) first = dots;  // the largest batch of the first kernel
        for (size_t k = 0; k < dots.size(); ++k) {
          ASSERT_EQ(dots[k], first[k]) << kernel << " d=" << d << " Q=" << nq << " entry " << k;
        }
      }
      if (kernel == "portable") continue;
      const RowMatrixXf distances = ComputeDistances(DistanceMetric::kEuclidean, q, map.set(0));
      if (first_distances.size() == 0) first_distances = distances;
      EXPECT_TRUE((distances.array() == first_distances.array()).all()) << kernel << " d=" << d;
    }
  }
  SetDistanceKernel("auto");
}

// The best SIMD kernel (FMA) and the portable one (multiply, then add) agree to rounding.
TEST(DescriptorStore, SimdAndPortableKernelsAgreeToRounding) {
  const std::string simd = testing::AvailableKernels().front();
  if (simd == "portable") GTEST_SKIP() << "this CPU runs no SIMD kernel";
  const RowMatrixXf q = testing::RandomMatrix(6, 517, 6);
  const ReferenceSet set = MakeReferenceSet("a", testing::RandomMatrix(30, 517, 7));
  SetDistanceKernel("portable");
  const RowMatrixXf portable = ComputeDistances(DistanceMetric::kEuclidean, q, set);
  SetDistanceKernel(simd);
  const RowMatrixXf vector = ComputeDistances(DistanceMetric::kEuclidean, q, set);
  SetDistanceKernel("auto");
  EXPECT_LT((portable - vector).cwiseAbs().maxCoeff(), 1e-4f * portable.cwiseAbs().maxCoeff());
  // int8 rows are summed exactly in integers: the two kernels agree to the bit.
  ReferenceSets map;
  map.SetStoragePrecision(StoragePrecision::kInt8);
  map.Add(MakeReferenceSet("a", testing::RandomMatrix(30, 517, 7)));
  SetDistanceKernel("portable");
  const RowMatrixXf portable8 = ComputeDistances(DistanceMetric::kCosine, q, map.set(0));
  SetDistanceKernel(simd);
  const RowMatrixXf avx8 = ComputeDistances(DistanceMetric::kCosine, q, map.set(0));
  SetDistanceKernel("auto");
  EXPECT_TRUE((portable8.array() == avx8.array()).all());
}

}  // namespace
}  // namespace bsf_vpr
