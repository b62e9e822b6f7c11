#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/core/stored_reference_set.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

// The stored rows, element by element, against the encoding written out here: float32 as
// given, binary16 rounded to nearest, int8 levels round(x / scale) with scale = max |x| / 127;
// each row decodes to what the kernels read, and its squared norm is that row's.
TEST(StoredReferenceSet, HoldsTheEncodedRowsBehindItsAccessorsAtEachPrecision) {
  ReferenceSet in;
  in.name = "winter";
  in.condition = "snow";
  in.descriptor_type = "test_5";
  in.distance = "cosine";
  in.descriptors = testing::RandomMatrix(4, 13, 3);
  in.descriptors(2, 7) = -9.5f;  // the largest |x|: int8 level -127
  in.place_ids = {7, 0, 3, 12};
  in.poses = {{1, 2, 3, 0.5}, {4, 5, 6, 0}, {7, 8, 9, 0}, {10, 11, 12, -1}};
  const float max_abs = 9.5f;
  for (StoragePrecision p :
       {StoragePrecision::kFloat32, StoragePrecision::kFloat16, StoragePrecision::kInt8}) {
    ReferenceSets map;
    map.SetStoragePrecision(p);
    map.Add(in);
    const StoredReferenceSet& set = map.set(0);
    const std::string where = ToString(p);
    EXPECT_EQ(set.name(), "winter");
    EXPECT_EQ(set.condition(), "snow");
    EXPECT_EQ(set.descriptor_type(), "test_5");
    EXPECT_EQ(set.distance(), "cosine");
    EXPECT_EQ(set.place_ids(), in.place_ids);
    ASSERT_EQ(set.poses().size(), 4u);
    EXPECT_EQ(set.poses()[3].yaw_rad, -1.0);
    EXPECT_EQ(set.size(), 4);
    EXPECT_EQ(set.dimension(), 13);
    EXPECT_EQ(set.precision(), p);
    EXPECT_EQ(set.data_bytes(), 4u * 13u * static_cast<size_t>(BytesPerElement(p))) << where;
    EXPECT_EQ(set.scale(), p == StoragePrecision::kInt8 ? max_abs / 127.0f : 1.0f) << where;
    ASSERT_EQ(set.squared_norms().size(), 4);
    std::vector<float> row(13);
    for (int r = 0; r < 4; ++r) {
      set.DecodeRow(r, row.data());
      double norm = 0;
      for (int k = 0; k < 13; ++k) {
        const float x = in.descriptors(r, k);
        const size_t i = static_cast<size_t>(r) * 13 + static_cast<size_t>(k);
        float expected = x;
        if (p == StoragePrecision::kFloat32) {
          EXPECT_EQ(static_cast<const float*>(set.data())[i], x);
        } else if (p == StoragePrecision::kFloat16) {
          EXPECT_EQ(static_cast<const uint16_t*>(set.data())[i], FloatToHalf(x));
          expected = HalfToFloat(FloatToHalf(x));
        } else {
          const int8_t level = static_cast<int8_t>(std::nearbyint(x / set.scale()));
          EXPECT_EQ(static_cast<const int8_t*>(set.data())[i], level) << r << " " << k;
          expected = set.scale() * level;
        }
        EXPECT_EQ(row[static_cast<size_t>(k)], expected) << where << " " << r << " " << k;
        norm += static_cast<double>(expected) * expected;
      }
      EXPECT_NEAR(set.squared_norms()(r), norm, 1e-5 * norm) << where << " row " << r;
    }
    if (p == StoragePrecision::kInt8) {  // the largest |x| takes the extreme level
      EXPECT_EQ(static_cast<const int8_t*>(set.data())[2 * 13 + 7], -127);
    }
  }
}

TEST(StoredReferenceSet, GivesBackItsInputAtFloat32AndRefusesAtReducedPrecision) {
  ReferenceSet in = MakeReferenceSet("route", testing::RandomMatrix(5, 8, 4), "rain");
  in.descriptor_type = "test_8";
  in.distance = "euclidean";
  in.place_ids = {4, 3, 2, 1, 9};
  in.poses = {{0, 0, 0, 0}, {1, 0, 0, 0}, {2, 0, 0, 0}, {3, 0, 0, 0}, {4, 0, 0, 0.25}};
  in.images = "/data/route";
  in.image_files = {"4.png", "3.png", "2.png", "1.png", "sub/9.png"};
  ReferenceSets map;
  map.Add(in);
  EXPECT_EQ(map.set(0).images(), in.images);
  EXPECT_EQ(map.set(0).image_files(), in.image_files);
  const ReferenceSet back = map.set(0).ToReferenceSet();
  EXPECT_EQ(back.images, in.images);
  EXPECT_EQ(back.image_files, in.image_files);
  EXPECT_EQ(back.name, in.name);
  EXPECT_EQ(back.condition, in.condition);
  EXPECT_EQ(back.descriptor_type, in.descriptor_type);
  EXPECT_EQ(back.distance, in.distance);
  EXPECT_TRUE((back.descriptors.array() == in.descriptors.array()).all());
  EXPECT_EQ(back.descriptors.rows(), 5);
  EXPECT_EQ(back.place_ids, in.place_ids);
  ASSERT_EQ(back.poses.size(), 5u);
  EXPECT_EQ(back.poses[4].x_m, 4.0);
  EXPECT_EQ(back.poses[4].yaw_rad, 0.25);
  EXPECT_NO_THROW(back.Validate());
  for (StoragePrecision p : {StoragePrecision::kFloat16, StoragePrecision::kInt8}) {
    ReferenceSets reduced;
    reduced.SetStoragePrecision(p);
    reduced.Add(in);
    EXPECT_EQ(reduced.set(0).image_files(), in.image_files);  // kept at every precision
    try {
      reduced.set(0).ToReferenceSet();
      ADD_FAILURE() << "a set held at " << ToString(p) << " gave back float32 descriptors";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("'route' is held at " + ToString(p) + " precision only"),
                std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("float32 source"), std::string::npos) << e.what();
    }
  }
}

TEST(StoredReferenceSet, CountsTheImageNamesInItsBytes) {
  ReferenceSet plain = MakeReferenceSet("a", testing::RandomMatrix(3, 4, 5));
  ReferenceSet named = plain;
  named.name = "b";
  named.images = "/data/images";
  named.image_files = {std::string(100, 'x') + ".png", "y.png", "z.png"};
  ReferenceSets map;
  map.Add(plain);
  map.Add(named);
  const size_t names = 12 + 104 + 5 + 5;  // the folder and the files' characters
  EXPECT_GE(map.set(1).MemoryBytes(), map.set(0).MemoryBytes() + names);
  EXPECT_LE(map.set(1).MemoryBytes(), map.set(0).MemoryBytes() + names + 3 * sizeof(std::string));
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

// Rows held elsewhere (a memory-mapped file, here a buffer the test keeps): the set holds
// them as they are, with the norms, distances and decoded rows of the same set encoded by
// the map, and keeps them alive through its copies.
TEST(StoredReferenceSet, HoldsEncodedRowsAsTheMapEncodesThem) {
  const RowMatrixXf x = testing::RandomMatrix(6, 21, 17);
  for (StoragePrecision p :
       {StoragePrecision::kFloat32, StoragePrecision::kFloat16, StoragePrecision::kInt8}) {
    ReferenceSets resident;
    resident.SetStoragePrecision(p);
    resident.Add(MakeReferenceSet("a", x));
    const StoredReferenceSet& r = resident.set(0);
    auto buffer = std::make_shared<std::vector<char>>(
        static_cast<const char*>(r.data()), static_cast<const char*>(r.data()) + r.data_bytes());
    ReferenceSet in = MakeReferenceSet("a", RowMatrixXf());
    in.place_ids = {0, 1, 2, 3, 4, 5};
    EncodedRows rows;
    rows.precision = p;
    rows.rows = 6;
    rows.cols = 21;
    rows.scale = r.scale();
    rows.data = buffer->data();
    rows.owner = buffer;
    rows.source = "'a.npy', memory-mapped";
    in.encoded = rows;
    buffer.reset();  // the set's copy of `owner` keeps it
    ReferenceSets mapped;
    mapped.SetStoragePrecision(p);
    mapped.Add(in);
    const StoredReferenceSet& m = mapped.set(0);
    EXPECT_TRUE(m.mapped());
    EXPECT_FALSE(r.mapped());
    EXPECT_EQ(m.rows_source(), "'a.npy', memory-mapped");
    EXPECT_EQ(m.size(), 6);
    EXPECT_EQ(m.dimension(), 21);
    EXPECT_EQ(m.scale(), r.scale());
    ASSERT_EQ(m.data_bytes(), r.data_bytes());
    EXPECT_EQ(std::memcmp(m.data(), r.data(), r.data_bytes()), 0);
    EXPECT_EQ(std::memcmp(m.squared_norms().data(), r.squared_norms().data(), 6 * sizeof(float)), 0)
        << ToString(p);
    const RowMatrixXf q = testing::RandomMatrix(2, 21, 19);
    const auto a = ComputeDistances(DistanceMetric::kEuclidean, q, resident);
    const auto b = ComputeDistances(DistanceMetric::kEuclidean, q, mapped);
    EXPECT_EQ(std::memcmp(a[0].data(), b[0].data(), sizeof(float) * a[0].size()), 0);
    const ReferenceSets copy = mapped;  // shares the rows
    mapped.Remove("a");
    EXPECT_EQ(std::memcmp(copy.set(0).data(), r.data(), r.data_bytes()), 0);
    if (p == StoragePrecision::kFloat32) {
      EXPECT_TRUE(copy.set(0).ToReferenceSet().descriptors.isApprox(x, 0));
    }
  }
}

TEST(StoredReferenceSet, RefusesEncodedRowsAtAnotherPrecisionOrNotFinite) {
  std::vector<float> values(12, 1.0f);
  values[7] = NAN;
  auto buffer = std::make_shared<std::vector<float>>(values);
  ReferenceSet in = MakeReferenceSet("b", RowMatrixXf());
  in.place_ids = {0, 1, 2};
  EncodedRows rows;
  rows.precision = StoragePrecision::kFloat32;
  rows.rows = 3;
  rows.cols = 4;
  rows.data = buffer->data();
  rows.owner = buffer;
  rows.source = "'b.npy', memory-mapped";
  in.encoded = rows;
  ReferenceSets int8;
  int8.SetStoragePrecision(StoragePrecision::kInt8);
  try {
    int8.Add(in);
    ADD_FAILURE() << "an int8 map took float32 rows";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("is held at float32 by 'b.npy', memory-mapped, but the "
                                         "map stores int8"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(int8.num_sets(), 0);
  ReferenceSets f32;
  try {
    f32.Add(in);
    ADD_FAILURE() << "a NaN row was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("descriptor row 1 of 'b.npy'"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(f32.num_sets(), 0);
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

// Store encodes a set aside (a map's owner does it before taking its lock); Add takes it
// as Add(ReferenceSet) would, and refuses it at another precision or against the layout,
// the map unchanged.
TEST(ReferenceSets, AddsASetStoredAsideAsItAddsOneItEncodes) {
  const RowMatrixXf x = testing::RandomMatrix(5, 12, 23);
  ReferenceSets direct, aside;
  direct.SetStoragePrecision(StoragePrecision::kInt8);
  aside.SetStoragePrecision(StoragePrecision::kInt8);
  direct.Add(MakeReferenceSet("a", x));
  aside.Add(ReferenceSets::Store(MakeReferenceSet("a", x), StoragePrecision::kInt8));
  ASSERT_EQ(aside.num_sets(), 1);
  EXPECT_EQ(aside.num_places(), direct.num_places());
  EXPECT_EQ(std::memcmp(aside.set(0).data(), direct.set(0).data(), direct.set(0).data_bytes()), 0);
  EXPECT_EQ(aside.set(0).scale(), direct.set(0).scale());

  EXPECT_THROW(aside.Add(ReferenceSets::Store(MakeReferenceSet("b", x), StoragePrecision::kFloat16)),
               std::invalid_argument);
  EXPECT_THROW(aside.Add(ReferenceSets::Store(MakeReferenceSet("a", x), StoragePrecision::kInt8)),
               std::invalid_argument);  // the name is taken
  EXPECT_EQ(aside.num_sets(), 1);
  EXPECT_THROW(ReferenceSets::Store(MakeReferenceSet("", x), StoragePrecision::kInt8),
               std::invalid_argument);
}

}  // namespace
}  // namespace bsf_vpr
