#include "bsf_vpr/core/descriptor_store.h"

#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>

namespace bsf_vpr {

const EnumNames<StoragePrecision>& StoragePrecisionNames() {
  static const EnumNames<StoragePrecision> kNames{{StoragePrecision::kFloat32, "float32"},
                                                  {StoragePrecision::kFloat16, "float16"},
                                                  {StoragePrecision::kInt8, "int8"}};
  return kNames;
}

StoragePrecision ParseStoragePrecision(const std::string& name) {
  // Not EnumNames::Parse's form: the tools' --storage has given this message all along.
  const std::optional<StoragePrecision> precision = StoragePrecisionNames().Find(name);
  if (!precision) {
    throw std::invalid_argument("unknown storage precision '" + name + "' (expected " +
                                StoragePrecisionNames().Listed() + ")");
  }
  return *precision;
}

std::string ToString(StoragePrecision precision) { return StoragePrecisionNames().Name(precision); }

int BytesPerElement(StoragePrecision precision) {
  return precision == StoragePrecision::kFloat32 ? 4
         : precision == StoragePrecision::kFloat16 ? 2
                                                     : 1;
}

uint16_t FloatToHalfOrInfinity(float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  const uint16_t sign = static_cast<uint16_t>((bits >> 16) & 0x8000u);
  const uint32_t magnitude = bits & 0x7fffffffu;
  if (magnitude > 0x7f800000u) return sign | 0x7e00u;   // NaN
  if (magnitude >= 0x477ff000u) return sign | 0x7c00u;  // infinity, or rounds beyond 65504
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

uint16_t FloatToHalf(float value) {
  const uint16_t half = FloatToHalfOrInfinity(value);
  if ((half & 0x7fffu) == 0x7c00u && std::isfinite(value)) {
    throw std::invalid_argument("value " + std::to_string(value) +
                                " is outside the float16 range (|x| <= 65504)");
  }
  return half;
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

}  // namespace bsf_vpr
