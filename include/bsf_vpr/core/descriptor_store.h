// How a reference set's descriptors are held for querying: float32 as given, or reduced to
// float16 (half the bytes) or int8 with one scale per set (a quarter of the bytes). Distance
// computation streams these bytes once per query, so its time falls with them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

enum class StoragePrecision { kFloat32, kFloat16, kInt8 };

// "float32", "float16" or "int8"; throws std::invalid_argument naming the bad value.
StoragePrecision ParseStoragePrecision(const std::string& name);
std::string ToString(StoragePrecision precision);
// Bytes per descriptor element: 4, 2 or 1.
int BytesPerElement(StoragePrecision precision);

// IEEE 754 binary16 conversions, rounding to nearest even. FloatToHalf throws
// std::invalid_argument for a finite value beyond float16's range (|x| > 65504).
uint16_t FloatToHalf(float value);
float HalfToFloat(uint16_t half);

// Reduced-precision copy of a set's descriptors plus the squared norm of every row (of the
// values the distance kernel reads, after rounding). For float32 only the norms are kept:
// the kernel reads the set's own float32 matrix.
struct DescriptorStore {
  StoragePrecision precision = StoragePrecision::kFloat32;
  int rows = 0, cols = 0;
  std::vector<uint16_t> half;   // rows x cols, row-major (float16)
  std::vector<int8_t> int8;     // rows x cols, row-major (int8)
  float scale = 1.0f;           // int8: value = scale * stored, scale = max |x| / 127
  Eigen::VectorXf squared_norms;  // rows entries; empty until built

  bool built() const { return squared_norms.size() == rows && rows > 0; }
  size_t MemoryBytes() const;
  // Row r as float32 (exact for float16; scale * stored for int8).
  void DecodeRow(int r, float* out) const;
};

// Builds the store of `descriptors` at `precision`. Throws std::invalid_argument for values
// float16 cannot hold.
DescriptorStore MakeDescriptorStore(const RowMatrixXf& descriptors, StoragePrecision precision);

}  // namespace bsf_vpr
