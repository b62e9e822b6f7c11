#include "bsf_vpr/core/descriptor_store.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "distance_kernels.h"

namespace bsf_vpr {

StoragePrecision ParseStoragePrecision(const std::string& name) {
  if (name == "float32") return StoragePrecision::kFloat32;
  if (name == "float16") return StoragePrecision::kFloat16;
  if (name == "int8") return StoragePrecision::kInt8;
  throw std::invalid_argument("unknown storage precision '" + name +
                              "' (expected float32, float16 or int8)");
}

std::string ToString(StoragePrecision precision) {
  switch (precision) {
    case StoragePrecision::kFloat16:
      return "float16";
    case StoragePrecision::kInt8:
      return "int8";
    default:
      return "float32";
  }
}

int BytesPerElement(StoragePrecision precision) {
  return precision == StoragePrecision::kFloat32 ? 4
         : precision == StoragePrecision::kFloat16 ? 2
                                                     : 1;
}

uint16_t FloatToHalf(float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  const uint16_t sign = static_cast<uint16_t>((bits >> 16) & 0x8000u);
  const uint32_t magnitude = bits & 0x7fffffffu;
  if (magnitude > 0x7f800000u) return sign | 0x7e00u;       // NaN
  if (magnitude == 0x7f800000u) return sign | 0x7c00u;      // infinity
  if (magnitude >= 0x477ff000u) {                           // rounds beyond 65504
    throw std::invalid_argument("value " + std::to_string(value) +
                                " is outside the float16 range (|x| <= 65504)");
  }
  if (magnitude < 0x38800000u) {  // below 2^-14: a subnormal half, m * 2^-24
    const float m = std::nearbyint(std::fabs(value) * 16777216.0f);  // exact scaling, RNE
    return sign | static_cast<uint16_t>(m);
  }
  const uint32_t exponent = (magnitude >> 23) - 127 + 15;
  const uint32_t mantissa = magnitude & 0x7fffffu;
  uint32_t half = (exponent << 10) | (mantissa >> 13);
  const uint32_t rest = mantissa & 0x1fffu;
  if (rest > 0x1000u || (rest == 0x1000u && (half & 1u))) ++half;  // may carry into exponent
  return sign | static_cast<uint16_t>(half);
}

float HalfToFloat(uint16_t half) {
  const uint32_t sign = static_cast<uint32_t>(half & 0x8000u) << 16;
  const uint32_t exponent = (half >> 10) & 0x1fu;
  const uint32_t mantissa = half & 0x3ffu;
  if (exponent == 0) {
    const float v = static_cast<float>(mantissa) * (1.0f / 16777216.0f);
    return sign ? -v : v;
  }
  const uint32_t bits = exponent == 31 ? sign | 0x7f800000u | (mantissa << 13)
                                       : sign | ((exponent + 112) << 23) | (mantissa << 13);
  float out;
  std::memcpy(&out, &bits, sizeof out);
  return out;
}

size_t DescriptorStore::MemoryBytes() const {
  return half.size() * sizeof(uint16_t) + int8.size() + squared_norms.size() * sizeof(float);
}

void DescriptorStore::DecodeRow(int r, float* out) const {
  const size_t base = static_cast<size_t>(r) * static_cast<size_t>(cols);
  for (int k = 0; k < cols; ++k) {
    out[k] = precision == StoragePrecision::kFloat16 ? HalfToFloat(half[base + k])
                                                     : scale * static_cast<float>(int8[base + k]);
  }
}

DescriptorStore MakeDescriptorStore(const RowMatrixXf& descriptors, StoragePrecision precision) {
  DescriptorStore store;
  store.precision = precision;
  store.rows = static_cast<int>(descriptors.rows());
  store.cols = static_cast<int>(descriptors.cols());
  const size_t n = static_cast<size_t>(descriptors.size());
  if (precision == StoragePrecision::kFloat16) {
    store.half.resize(n);
    for (size_t i = 0; i < n; ++i) store.half[i] = FloatToHalf(descriptors.data()[i]);
  } else if (precision == StoragePrecision::kInt8) {
    const float max_abs = n ? descriptors.cwiseAbs().maxCoeff() : 0.0f;
    store.scale = max_abs > 0 ? max_abs / 127.0f : 1.0f;
    store.int8.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const float q = std::nearbyint(descriptors.data()[i] / store.scale);
      store.int8[i] = static_cast<int8_t>(std::clamp(q, -127.0f, 127.0f));
    }
  }
  store.squared_norms.resize(store.rows);
  std::vector<float> row(static_cast<size_t>(store.cols));
  for (int r = 0; r < store.rows; ++r) {
    const float* values = descriptors.row(r).data();
    if (precision != StoragePrecision::kFloat32) {
      store.DecodeRow(r, row.data());
      values = row.data();
    }
    store.squared_norms(r) = kernels::SelfDot(values, store.cols);
  }
  return store;
}

}  // namespace bsf_vpr
