#include "bsf_vpr/core/sharding.h"

#include <cstring>

namespace bsf_vpr {
namespace {

// FNV-1a over 64-bit words (the tail byte by byte): fast enough for gigabytes at load time;
// the fingerprint tells sets apart, it is not a defence against a forger.
class Hasher {
 public:
  void Add(const void* data, size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    size_t i = 0;
    for (; i + 8 <= bytes; i += 8) {
      uint64_t word;
      std::memcpy(&word, p + i, 8);
      Mix(word);
    }
    for (; i < bytes; ++i) Mix(p[i]);
    Mix(bytes);  // "ab" + "c" differs from "a" + "bc"
  }
  template <typename T>
  void AddValue(const T& value) {
    Add(&value, sizeof(value));
  }
  uint64_t value() const { return hash_; }

 private:
  void Mix(uint64_t word) {
    hash_ ^= word;
    hash_ *= 0x100000001b3ULL;
    hash_ ^= hash_ >> 29;
  }
  uint64_t hash_ = 0xcbf29ce484222325ULL;
};

}  // namespace

uint64_t SetFingerprint(const StoredReferenceSet& set) {
  Hasher h;
  h.Add(set.name().data(), set.name().size());
  h.Add(set.place_ids().data(), set.place_ids().size() * sizeof(int));
  for (const PlacePose& p : set.poses()) {
    const double values[4] = {p.x_m, p.y_m, p.z_m, p.yaw_rad};
    h.Add(values, sizeof(values));
  }
  h.AddValue(static_cast<int>(set.precision()));
  h.AddValue(set.scale());
  h.AddValue(set.dimension());
  if (set.data_bytes() > 0) h.Add(set.data(), set.data_bytes());
  return h.value();
}

}  // namespace bsf_vpr
