// libFuzzer target for the core's .npy reader.
//
// Every input is decoded from memory by DecodeNpyMatrix (the decoder behind ReadNpyMatrix)
// and DecodeNpyBoolMatrix, and its header parsed by ParseNpyHeader. The decoders accept
// nothing the header parser refuses; of what it accepts, DecodeNpyMatrix takes exactly the
// float dtypes and DecodeNpyBoolMatrix exactly the matrices whose every element is 0 or 1.
// An accepted input is
//  - decoded again here, independently, from libFuzzer's own buffer, which is exactly the
//    input's size, so that AddressSanitizer reports any read that the header's promise ("the
//    data fits") would not cover; both decodings must agree bit for bit (a Fortran-order
//    input is transposed by both), and so must the truth matrices;
//  - re-encoded as float32 (EncodeNpyMatrix, always C order) and parsed again: same shape;
//  - loaded as a reference set through the file path (LoadReferenceSetNpy: its size limits,
//    the place ids, the validation), from a file in a private temporary folder. Only accepted
//    inputs pay for the file; most inputs are refused.
//
// A std::exception from the core is the expected answer to a bad file. Anything else is a
// finding: a crash, a sanitizer report, an allocation beyond -malloc_limit_mb, or one of the
// disagreements above (reported as "FINDING: ..." followed by abort()).
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <optional>
#include <string>

#include "bsf_vpr/io/npy.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "test/fuzz/fuzz_fixture.h"

namespace bsf_vpr {
namespace fuzz {
namespace {

std::string g_dir;   // private temporary folder, made once
std::string g_path;  // <g_dir>/input.npy

void RemoveTempDir() {
  std::remove(g_path.c_str());
  rmdir(g_dir.c_str());
}

[[noreturn]] void Finding(const std::string& what) {
  std::fprintf(stderr, "FINDING: %s\n", what.c_str());
  std::abort();
}

size_t ElementBytes(NpyDtype dtype) {
  const size_t bytes = NpyDtypeBytes(dtype);
  if (bytes == 0) Finding("ParseNpyHeader returned an unknown dtype");
  return bytes;
}

// Decodes the elements the header describes, reading only
// data[h.data_offset, h.data_offset + rows * cols * element bytes). Element (r, c) is the
// (r * cols + c)-th of the file in C order and the (c * rows + r)-th in Fortran order.
RowMatrixXf Decode(const uint8_t* data, const NpyHeader& h) {
  RowMatrixXf m(h.rows, h.cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    const Eigen::Index r = i / m.cols(), c = i % m.cols();
    const Eigen::Index k = h.fortran_order ? c * m.rows() + r : i;
    const uint8_t* p = data + h.data_offset + k * ElementBytes(h.dtype);
    switch (h.dtype) {
      case NpyDtype::kFloat16: {
        uint16_t bits;
        std::memcpy(&bits, p, 2);
        m.data()[i] = static_cast<float>(Eigen::numext::bit_cast<Eigen::half>(bits));
        break;
      }
      case NpyDtype::kFloat32:
        std::memcpy(m.data() + i, p, 4);
        break;
      case NpyDtype::kFloat64: {
        double v;
        std::memcpy(&v, p, 8);
        m.data()[i] = static_cast<float>(v);
        break;
      }
      default:
        Finding("Decode called for a dtype that is not a float");
    }
  }
  return m;
}

template <typename T>
double As(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return static_cast<double>(v);
}

// The element at `p` as a double: whether it is exactly 0 or 1 survives the conversion.
double Value(const uint8_t* p, NpyDtype dtype) {
  switch (dtype) {
    case NpyDtype::kFloat16: {
      uint16_t bits;
      std::memcpy(&bits, p, 2);
      return static_cast<float>(Eigen::numext::bit_cast<Eigen::half>(bits));
    }
    case NpyDtype::kFloat32:
      return As<float>(p);
    case NpyDtype::kFloat64:
      return As<double>(p);
    case NpyDtype::kBool:
    case NpyDtype::kUInt8:
      return As<uint8_t>(p);
    case NpyDtype::kInt8:
      return As<int8_t>(p);
    case NpyDtype::kInt16:
      return As<int16_t>(p);
    case NpyDtype::kUInt16:
      return As<uint16_t>(p);
    case NpyDtype::kInt32:
      return As<int32_t>(p);
    case NpyDtype::kUInt32:
      return As<uint32_t>(p);
    case NpyDtype::kInt64:
      return As<int64_t>(p);
    case NpyDtype::kUInt64:
      return As<uint64_t>(p);
  }
  Finding("ParseNpyHeader returned an unknown dtype");
}

// The truth matrix the elements describe (0 false, 1 true), or nothing if any element is
// another value. Reads the same bytes as Decode.
std::optional<RowMatrixXb> DecodeTruth(const uint8_t* data, const NpyHeader& h) {
  RowMatrixXb m(h.rows, h.cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    const Eigen::Index r = i / m.cols(), c = i % m.cols();
    const Eigen::Index k = h.fortran_order ? c * m.rows() + r : i;
    const double v = Value(data + h.data_offset + k * ElementBytes(h.dtype), h.dtype);
    if (v != 0 && v != 1) return std::nullopt;
    m.data()[i] = v == 1;
  }
  return m;
}

bool SameBits(const RowMatrixXf& a, const RowMatrixXf& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(float) * a.size()) == 0);
}

// Not Eigen's operator!=, which walks every column of a 0 x 4e9 matrix.
bool SameTruth(const RowMatrixXb& a, const RowMatrixXb& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::equal(a.data(), a.data() + a.size(), b.data());
}

void WriteInput(const uint8_t* data, size_t size) {
  std::FILE* f = std::fopen(g_path.c_str(), "wb");
  if (f == nullptr || std::fwrite(data, 1, size, f) != size || std::fclose(f) != 0) {
    std::fprintf(stderr, "fuzz_npy: cannot write '%s'\n", g_path.c_str());
    std::exit(2);
  }
}

std::string Shape(int64_t rows, int64_t cols) {
  return "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")";
}

}  // namespace
}  // namespace fuzz
}  // namespace bsf_vpr

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  using namespace bsf_vpr::fuzz;
  g_dir = MakePrivateTempDir("bsf_fuzz_npy");
  g_path = g_dir + "/input.npy";
  std::atexit(RemoveTempDir);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace bsf_vpr;
  using namespace bsf_vpr::fuzz;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  std::optional<RowMatrixXf> decoded;
  std::string decode_error;
  try {
    decoded = DecodeNpyMatrix(bytes, "input");
  } catch (const std::exception& e) {
    decode_error = e.what();
  }
  std::optional<RowMatrixXb> truth;
  std::string truth_error;
  try {
    truth = DecodeNpyBoolMatrix(bytes, "input");
  } catch (const std::exception& e) {
    truth_error = e.what();
  }
  NpyHeader h;
  try {
    h = ParseNpyHeader(bytes, "input");
  } catch (const std::exception& e) {
    if (decoded) Finding(std::string("DecodeNpyMatrix accepted a header refused: ") + e.what());
    if (truth) Finding(std::string("DecodeNpyBoolMatrix accepted a header refused: ") + e.what());
    return 0;
  }

  // The header's promise, in exact arithmetic.
  const unsigned __int128 need = static_cast<unsigned __int128>(h.rows < 0 ? 0 : h.rows) *
                                 static_cast<unsigned __int128>(h.cols < 0 ? 0 : h.cols) *
                                 ElementBytes(h.dtype);
  if (h.rows < 0 || h.cols < 0 || h.data_offset > size || need > size - h.data_offset) {
    Finding("ParseNpyHeader accepted shape " + Shape(h.rows, h.cols) + " at offset " +
            std::to_string(h.data_offset) + " for " + std::to_string(size) + " bytes");
  }

  // A truth matrix exactly when every element is 0 or 1, whatever the dtype.
  const std::optional<RowMatrixXb> expected_truth = DecodeTruth(data, h);
  if (truth.has_value() != expected_truth.has_value()) {
    Finding(truth ? "DecodeNpyBoolMatrix accepted a value other than 0 and 1"
                  : "DecodeNpyBoolMatrix refused a matrix of 0 and 1: " + truth_error);
  }
  if (truth && !SameTruth(*truth, *expected_truth)) {
    Finding("DecodeNpyBoolMatrix disagrees with the elements decoded here, shape " +
            Shape(h.rows, h.cols));
  }

  // A float matrix exactly for the float dtypes.
  if (decoded.has_value() != IsFloatDtype(h.dtype)) {
    Finding(std::string(decoded ? "DecodeNpyMatrix accepted " : "DecodeNpyMatrix refused ") +
            NpyDtypeName(h.dtype) + " data (" + decode_error + ")");
  }
  if (!decoded) return 0;
  if (!SameBits(*decoded, Decode(data, h))) {
    Finding("DecodeNpyMatrix disagrees with the header's shape " + Shape(h.rows, h.cols) +
            " or with the elements decoded here");
  }

  try {
    const std::string encoded = EncodeNpyMatrix(*decoded);
    const NpyHeader back = ParseNpyHeader(encoded, "re-encoded");
    if (back.rows != h.rows || back.cols != h.cols || back.dtype != NpyDtype::kFloat32 ||
        back.fortran_order ||
        back.data_offset + 4 * static_cast<size_t>(decoded->size()) != encoded.size()) {
      Finding("EncodeNpyMatrix of shape " + Shape(h.rows, h.cols) + " parses back as " +
              Shape(back.rows, back.cols));
    }
  } catch (const std::exception& e) {
    Finding("the re-encoded matrix " + Shape(h.rows, h.cols) + " is refused: " + e.what());
  }

  WriteInput(data, size);
  try {
    LoadReferenceSetNpy(g_path, "fuzz");
  } catch (const std::exception&) {
  }
  return 0;
}
