// How a reference set's descriptors are held for querying: float32 as given, or reduced to
// float16 (half the bytes) or int8 with one scale per set (a quarter of the bytes). Distance
// computation streams these bytes once per query, so its time falls with them. The encoded
// rows are held by StoredReferenceSet (stored_reference_set.h).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "bsf_vpr/core/enum_names.h"

namespace bsf_vpr {

enum class StoragePrecision { kFloat32, kFloat16, kInt8 };

// The precisions' names (the storage of parameters, flags and shard answers).
const EnumNames<StoragePrecision>& StoragePrecisionNames();
// A name of StoragePrecisionNames(); throws std::invalid_argument naming the bad value and
// the choices otherwise.
StoragePrecision ParseStoragePrecision(const std::string& name);
std::string ToString(StoragePrecision precision);
// Bytes per descriptor element: 4, 2 or 1.
int BytesPerElement(StoragePrecision precision);

// The smallest scale of int8 rows (an element stands for scale x its value): sqrt(FLT_MIN).
// Below it the square of one level underflows float, so a row's squared norm and its
// distances lose their digits (at 1e-25 every row decodes to zero): such a scale is refused.
constexpr float kMinInt8Scale = 1.0842022e-19f;

// Rows already encoded at a storage precision, held by someone else: a reference set's .npy
// memory-mapped (io/reference_set_io.h, ReadSetOptions::memory_map), so that a map holds the
// set without reading its bytes. `owner` keeps `data` valid (the mapping is undone when the
// last copy goes). A save never rewrites a mapped file in place (it writes new files and
// renames, so a mapped file's pages stay those of the old file); another program may, and
// `changed` then says so: the map drops the set rather than use its rows.
struct EncodedRows {
  StoragePrecision precision = StoragePrecision::kFloat32;
  int64_t rows = 0;
  int64_t cols = 0;
  // int8: an element stands for scale x its value; 1 for the other precisions.
  float scale = 1.0f;
  const void* data = nullptr;  // rows x cols elements of `precision`, row-major
  std::shared_ptr<const void> owner;
  std::string source;  // where the rows are, for messages ("'winter.npy', memory-mapped")
  // Why the rows may no longer be those loaded ("" while they are): their file was changed
  // in place by another program. Empty: they cannot change. Asked around every read.
  std::function<std::string()> changed;

  size_t bytes() const {
    return static_cast<size_t>(rows) * static_cast<size_t>(cols) *
           static_cast<size_t>(BytesPerElement(precision));
  }
};

// IEEE 754 binary16 conversions, rounding to nearest even; NaN stays a (quiet) NaN and
// infinity infinity. bsf_vpr's one float16 implementation: the stores, the portable distance
// kernel and the .npy reader and writer all use it. A finite value that rounds beyond
// float16's range (|x| > 65504) makes FloatToHalf throw std::invalid_argument (a store
// refuses it) and becomes an infinity of its sign in FloatToHalfOrInfinity (as NumPy's
// astype(float16) writes it).
uint16_t FloatToHalf(float value);
uint16_t FloatToHalfOrInfinity(float value);
float HalfToFloat(uint16_t half);

}  // namespace bsf_vpr
