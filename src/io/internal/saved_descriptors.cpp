#include "src/io/internal/saved_descriptors.h"

#include <cstdint>
#include <cstdio>

namespace bsf_vpr {
namespace {

constexpr size_t kHashDigits = 12;
constexpr char kSuffix[] = ".npy";
constexpr size_t kSuffixSize = sizeof(kSuffix) - 1;

// FNV-1a, 64 bits: names a descriptor file by its content.
uint64_t ContentHash(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;
  }
  return h;
}

std::string HashDigits(const std::string& bytes) {
  char hash[17];
  std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(ContentHash(bytes)));
  return std::string(hash, kHashDigits);
}

}  // namespace

std::string ContentDigest(const std::string& bytes) {
  char hash[17];
  std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(ContentHash(bytes)));
  return hash;
}

std::string SavedDescriptorPath(const std::string& stem, const std::string& npy_bytes) {
  return stem + "." + HashDigits(npy_bytes) + kSuffix;
}

bool HasSavedDescriptorName(const std::string& file_name) {
  // "<stem>.<12 hex>.npy" with a stem of at least one character.
  const size_t tail = 1 + kHashDigits + kSuffixSize;
  if (file_name.size() <= tail || file_name.find('/') != std::string::npos) return false;
  const size_t dot = file_name.size() - tail;
  if (file_name[dot] != '.' ||
      file_name.compare(file_name.size() - kSuffixSize, kSuffixSize, kSuffix) != 0) {
    return false;
  }
  for (size_t i = dot + 1; i < dot + 1 + kHashDigits; ++i) {
    const char c = file_name[i];
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

bool IsSavedDescriptorFile(const std::string& file_name, const std::string& bytes) {
  if (!HasSavedDescriptorName(file_name)) return false;
  const size_t digits = file_name.size() - kSuffixSize - kHashDigits;
  return file_name.compare(digits, kHashDigits, HashDigits(bytes)) == 0;
}

}  // namespace bsf_vpr
