#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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
    ReferenceMap map;
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
  ReferenceMap map;
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
      ReferenceMap map;
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

// AVX-512 does float32 batches two queries to a register, and float32 and float16 batches by
// lane from 32 queries, in AVX2's order: the same bits, on batches that take every tile shape,
// any thread count and both metrics.
TEST(DescriptorStore, Avx512AndAvx2KernelsGiveTheSameBits) {
  const std::vector<std::string> kernels = testing::AvailableKernels();
  if (std::find(kernels.begin(), kernels.end(), "avx512") == kernels.end()) {
    GTEST_SKIP() << "this CPU has no AVX-512";
  }
  // 19 and 20 queries: a tile of 8 with pairs and one query left over, or pairs only. 32 and
  // more: by lane (kPackQueries), in panels of 12 queries (37: three and one of 1; 36: three
  // whole; 100: eight and one of 4) and of 32 rows, whole and partial (the rows are split
  // between the threads only for a large enough batch), with elements past d in the last step
  // (d = 5, 13, 1029, 1031, 2051).
  for (auto [nq, d, rows] :
       {std::tuple{19, 8, 197}, std::tuple{20, 517, 197}, std::tuple{19, 1029, 197},
        std::tuple{20, 1029, 197}, std::tuple{16, 4096, 197}, std::tuple{37, 13, 197},
        std::tuple{37, 1029, 110}, std::tuple{40, 2051, 197}, std::tuple{40, 4096, 110},
        std::tuple{32, 5, 20}, std::tuple{36, 8, 65}, std::tuple{100, 1031, 70}}) {
    const RowMatrixXf q = testing::RandomMatrix(nq, d, 8);
    for (StoragePrecision p : {StoragePrecision::kFloat32, StoragePrecision::kFloat16}) {
      ReferenceMap map;
      map.SetStoragePrecision(p);
      map.Add(MakeReferenceSet("a", testing::RandomMatrix(rows, d, 9)));
      for (DistanceMetric m : {DistanceMetric::kEuclidean, DistanceMetric::kCosine}) {
        const testing::ScopedDistanceThreads threads(2);
        SetDistanceKernel("avx2");
        const RowMatrixXf avx2 = ComputeDistances(m, q, map.set(0));
        SetDistanceKernel("avx512");
        const RowMatrixXf avx512 = ComputeDistances(m, q, map.set(0));
        SetDistanceKernel("auto");
        EXPECT_TRUE((avx2.array() == avx512.array()).all())
            << nq << " queries, d=" << d << " " << ToString(m) << " " << ToString(p);
      }
    }
  }
}

// The lane tiles' inner products themselves (not only the distances made from them, which
// can absorb a last-bit difference): bit for bit the AVX2 kernel's, float32 and float16 rows,
// for panels of queries whole and partial (32, 37, 100), panels of rows whole, partial, of
// exactly 16 and under 16 (1, 16, 17, 33, 48, 70), rows shorter than a block and with a tail
// (d = 1, 5, 8, 13, 1031), and queries prepared on one kernel and run on the other.
TEST(DescriptorStore, LaneTilesGiveTheAvx2KernelsInnerProducts) {
  const std::vector<std::string> kernels = testing::AvailableKernels();
  if (std::find(kernels.begin(), kernels.end(), "avx512") == kernels.end()) {
    GTEST_SKIP() << "this CPU has no AVX-512";
  }
  for (const int d : {1, 5, 8, 13, 1031}) {
    const RowMatrixXf q = testing::RandomMatrix(100, d, 41);
    const RowMatrixXf rows = testing::RandomMatrix(70, d, 42);
    std::vector<uint16_t> halves(static_cast<size_t>(rows.size()));
    for (Eigen::Index k = 0; k < rows.size(); ++k) {
      halves[static_cast<size_t>(k)] = FloatToHalf(rows.data()[k]);
    }
    for (const StoragePrecision p : {StoragePrecision::kFloat32, StoragePrecision::kFloat16}) {
      kernels::RefRows refs;
      refs.precision = p;
      refs.data = p == StoragePrecision::kFloat32 ? static_cast<const void*>(rows.data())
                                                  : static_cast<const void*>(halves.data());
      refs.cols = d;
      for (const int nq : {32, 37, 100}) {
        for (const int count : {1, 16, 17, 33, 48, 70}) {
          const auto dots = [&](const std::string& prepare_on, const std::string& run_on) {
            SetDistanceKernel(prepare_on);
            const kernels::Queries prepared = kernels::PrepareQueries(q.data(), nq, d, d, false);
            SetDistanceKernel(run_on);
            std::vector<float> out(static_cast<size_t>(nq) * count, -1.0f);
            kernels::Dots(refs, 0, count, prepared, out.data(), count);
            return out;
          };
          const std::vector<float> avx2 = dots("avx2", "avx2");
          const std::string at = ToString(p) + " d=" + std::to_string(d) +
                                 " Q=" + std::to_string(nq) + " rows=" + std::to_string(count);
          for (const auto& [prepare_on, run_on] :
               {std::pair{"avx512", "avx512"}, std::pair{"avx512", "avx2"},
                std::pair{"avx2", "avx512"}}) {
            const std::vector<float> other = dots(prepare_on, run_on);
            ASSERT_EQ(std::memcmp(other.data(), avx2.data(), avx2.size() * sizeof(float)), 0)
                << at << ", prepared on " << prepare_on << ", run on " << run_on;
          }
        }
      }
    }
  }
  SetDistanceKernel("auto");
}

// Every kernel (AVX2 and AVX-512 where the CPU has them, and the portable one), every storage and
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
      ReferenceMap map;
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

// int8 rows are summed exactly in integers: every kernel the CPU has (VNNI's 32 products an
// instruction, AVX2's 16, the portable loop) gives the same inner products, bit for bit, for
// every tile shape and row length (whole 32-element steps or a tail); the distances too on
// the vector kernels (the portable one rounds the query's float norm in another order).
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
    ReferenceMap map;
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

TEST(DescriptorStore, AvxAndPortableKernelsAgreeToRounding) {
  const std::vector<std::string> kernels = testing::AvailableKernels();
  if (std::find(kernels.begin(), kernels.end(), "avx2") == kernels.end()) {
    GTEST_SKIP() << "this CPU has no AVX2";
  }
  const RowMatrixXf q = testing::RandomMatrix(6, 517, 6);
  const ReferenceSet set = MakeReferenceSet("a", testing::RandomMatrix(30, 517, 7));
  SetDistanceKernel("portable");
  const RowMatrixXf portable = ComputeDistances(DistanceMetric::kEuclidean, q, set);
  SetDistanceKernel("avx2");
  const RowMatrixXf avx2 = ComputeDistances(DistanceMetric::kEuclidean, q, set);
  SetDistanceKernel("auto");
  EXPECT_LT((portable - avx2).cwiseAbs().maxCoeff(), 1e-4f * portable.cwiseAbs().maxCoeff());
  // int8 rows are summed exactly in integers: the two kernels agree to the bit.
  ReferenceMap map;
  map.SetStoragePrecision(StoragePrecision::kInt8);
  map.Add(MakeReferenceSet("a", testing::RandomMatrix(30, 517, 7)));
  SetDistanceKernel("portable");
  const RowMatrixXf portable8 = ComputeDistances(DistanceMetric::kCosine, q, map.set(0));
  SetDistanceKernel("avx2");
  const RowMatrixXf avx8 = ComputeDistances(DistanceMetric::kCosine, q, map.set(0));
  SetDistanceKernel("auto");
  EXPECT_TRUE((portable8.array() == avx8.array()).all());
}

}  // namespace
}  // namespace bsf_vpr
