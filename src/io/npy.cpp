#include "bsf_vpr/io/npy.h"

#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "bsf_vpr/core/descriptor_store.h"  // the float16 conversions
#include "bsf_vpr/io/file_util.h"

namespace bsf_vpr {
namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr size_t kMagicSize = 6;

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("'" + path + "' is not a usable .npy matrix: " + what);
}

// Returns the text that follows `'key':` in the header dictionary, with leading blanks
// skipped, or fails if the key is missing.
std::string ValueAfterKey(const std::string& header, const std::string& key,
                          const std::string& path) {
  const std::string quoted = "'" + key + "'";
  size_t pos = header.find(quoted);
  if (pos == std::string::npos) Fail(path, "header has no " + quoted + " entry");
  pos = header.find(':', pos + quoted.size());
  if (pos == std::string::npos) Fail(path, "header entry " + quoted + " has no value");
  ++pos;
  while (pos < header.size() && std::isspace(static_cast<unsigned char>(header[pos]))) ++pos;
  return header.substr(pos);
}

struct DtypeInfo {
  NpyDtype dtype;
  const char* descr;  // as NumPy writes it
  const char* name;
  size_t bytes;
};

// Indexed by NpyDtype.
constexpr DtypeInfo kDtypes[] = {
    {NpyDtype::kFloat16, "<f2", "float16", 2}, {NpyDtype::kFloat32, "<f4", "float32", 4},
    {NpyDtype::kFloat64, "<f8", "float64", 8}, {NpyDtype::kBool, "|b1", "bool", 1},
    {NpyDtype::kInt8, "|i1", "int8", 1},       {NpyDtype::kUInt8, "|u1", "uint8", 1},
    {NpyDtype::kInt16, "<i2", "int16", 2},     {NpyDtype::kUInt16, "<u2", "uint16", 2},
    {NpyDtype::kInt32, "<i4", "int32", 4},     {NpyDtype::kUInt32, "<u4", "uint32", 4},
    {NpyDtype::kInt64, "<i8", "int64", 8},     {NpyDtype::kUInt64, "<u8", "uint64", 8},
};

constexpr size_t kNumDtypes = sizeof(kDtypes) / sizeof(kDtypes[0]);

constexpr bool IndexedByDtype() {
  for (size_t i = 0; i < kNumDtypes; ++i) {
    if (static_cast<size_t>(kDtypes[i].dtype) != i) return false;
  }
  return true;
}
static_assert(IndexedByDtype(), "kDtypes must list the NpyDtype values in order");

const DtypeInfo& Info(NpyDtype dtype) {
  const size_t i = static_cast<size_t>(dtype);
  if (i >= kNumDtypes) throw std::invalid_argument("unknown NpyDtype " + std::to_string(i));
  return kDtypes[i];
}

const char kFloatDtypes[] = "float16 '<f2', float32 '<f4' or float64 '<f8'";

NpyDtype ParseDescr(const std::string& value, const std::string& path) {
  if (value.empty() || (value[0] != '\'' && value[0] != '"')) Fail(path, "'descr' is not a string");
  const size_t end = value.find(value[0], 1);
  if (end == std::string::npos) Fail(path, "'descr' string is not terminated");
  const std::string descr = value.substr(1, end - 1);
  for (const DtypeInfo& d : kDtypes) {
    if (descr == d.descr) return d.dtype;
    // A single byte has no byte order: NumPy writes '|', other writers (cnpy) '<'.
    if (d.bytes == 1 && descr == "<" + std::string(d.descr + 1)) return d.dtype;
  }
  Fail(path, "dtype '" + descr + "' is not supported (expected little-endian " + kFloatDtypes +
                 ", bool '|b1', or an integer '|i1' '|u1' '<i2' '<u2' '<i4' '<u4' '<i8' '<u8')");
}

std::vector<int64_t> ParseShape(const std::string& value, const std::string& path) {
  if (value.empty() || value[0] != '(') Fail(path, "'shape' is not a tuple");
  const size_t end = value.find(')');
  if (end == std::string::npos) Fail(path, "'shape' tuple is not terminated");
  std::vector<int64_t> shape;
  size_t i = 1;
  while (i < end) {
    while (i < end && (std::isspace(static_cast<unsigned char>(value[i])) || value[i] == ',')) ++i;
    if (i >= end) break;
    if (!std::isdigit(static_cast<unsigned char>(value[i])))
      Fail(path, "'shape' holds a non-integer");
    int64_t dim = 0;
    while (i < end && std::isdigit(static_cast<unsigned char>(value[i]))) {
      if (dim > kMaxNpyElements) Fail(path, "a dimension in 'shape' is absurdly large");
      dim = dim * 10 + (value[i] - '0');
      ++i;
    }
    shape.push_back(dim);
  }
  return shape;
}

template <typename T>
T Load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// Decodes every element of the data with `decode(pointer to its bytes)` into `out`, the
// header's rows x cols in row-major order. The file's k-th element is (k / cols, k % cols)
// in C order and (k % rows, k / rows) in Fortran order, which is transposed here.
template <typename T, typename Decode>
void DecodeRowMajor(const char* data, const NpyHeader& h, Decode decode, T* out) {
  if (h.rows == 0 || h.cols == 0) return;  // not a loop over 4e9 empty columns
  const size_t bytes = NpyDtypeBytes(h.dtype);
  if (!h.fortran_order) {
    const int64_t n = h.rows * h.cols;
    for (int64_t k = 0; k < n; ++k) out[k] = decode(data + static_cast<size_t>(k) * bytes);
    return;
  }
  for (int64_t c = 0; c < h.cols; ++c) {
    const char* column = data + static_cast<size_t>(c * h.rows) * bytes;
    for (int64_t r = 0; r < h.rows; ++r) {
      out[r * h.cols + c] = decode(column + static_cast<size_t>(r) * bytes);
    }
  }
}

// 0 or 1 for an element that is 0 or 1, 2 for any other value (NaN included).
template <typename Stored>
uint8_t TruthOf(const char* p) {
  const Stored v = Load<Stored>(p);
  return v == Stored(0) ? 0 : v == Stored(1) ? 1 : 2;
}

// The same for float16 bits: every float16 value is exact in float32.
uint8_t HalfTruthOf(const char* p) {
  const float v = HalfToFloat(Load<uint16_t>(p));
  return v == 0.0f ? 0 : v == 1.0f ? 1 : 2;
}

// The element at `p` as text, exactly for integers (bools as their byte).
std::string ElementText(const char* p, NpyDtype dtype) {
  char buf[32];
  switch (dtype) {
    case NpyDtype::kFloat16:
      std::snprintf(buf, sizeof(buf), "%.9g", HalfToFloat(Load<uint16_t>(p)));
      return buf;
    case NpyDtype::kFloat32:
      std::snprintf(buf, sizeof(buf), "%.9g", Load<float>(p));
      return buf;
    case NpyDtype::kFloat64:
      std::snprintf(buf, sizeof(buf), "%.17g", Load<double>(p));
      return buf;
    case NpyDtype::kBool:
      return "the byte " + std::to_string(Load<uint8_t>(p));
    case NpyDtype::kInt8:
      return std::to_string(Load<int8_t>(p));
    case NpyDtype::kUInt8:
      return std::to_string(Load<uint8_t>(p));
    case NpyDtype::kInt16:
      return std::to_string(Load<int16_t>(p));
    case NpyDtype::kUInt16:
      return std::to_string(Load<uint16_t>(p));
    case NpyDtype::kInt32:
      return std::to_string(Load<int32_t>(p));
    case NpyDtype::kUInt32:
      return std::to_string(Load<uint32_t>(p));
    case NpyDtype::kInt64:
      return std::to_string(Load<int64_t>(p));
    case NpyDtype::kUInt64:
      return std::to_string(Load<uint64_t>(p));
  }
  return "?";
}

}  // namespace

size_t NpyDtypeBytes(NpyDtype dtype) { return Info(dtype).bytes; }

bool IsFloatDtype(NpyDtype dtype) {
  return dtype == NpyDtype::kFloat16 || dtype == NpyDtype::kFloat32 || dtype == NpyDtype::kFloat64;
}

const char* NpyDtypeName(NpyDtype dtype) { return Info(dtype).name; }

const char* NpyDtypeDescr(NpyDtype dtype) { return Info(dtype).descr; }

NpyHeader ParseNpyHeader(std::string_view bytes, const std::string& path) {
  if (bytes.size() < 10 || std::memcmp(bytes.data(), kMagic, kMagicSize) != 0) {
    Fail(path, "missing the \\x93NUMPY magic string");
  }
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len = 0;
  size_t header_start = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(bytes[8]) |
                 (static_cast<size_t>(static_cast<unsigned char>(bytes[9])) << 8);
    header_start = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) Fail(path, "truncated header");
    for (int k = 3; k >= 0; --k) {
      header_len = (header_len << 8) | static_cast<unsigned char>(bytes[8 + k]);
    }
    header_start = 12;
  } else {
    Fail(path, "format version " + std::to_string(major) + " is not supported");
  }
  if (header_start + header_len > bytes.size()) Fail(path, "truncated header");
  const std::string header(bytes.substr(header_start, header_len));

  NpyHeader result;
  result.dtype = ParseDescr(ValueAfterKey(header, "descr", path), path);
  const std::string fortran = ValueAfterKey(header, "fortran_order", path);
  if (fortran.rfind("True", 0) == 0) {
    result.fortran_order = true;
  } else if (fortran.rfind("False", 0) != 0) {
    Fail(path, "'fortran_order' is neither True nor False");
  }
  const std::vector<int64_t> shape = ParseShape(ValueAfterKey(header, "shape", path), path);
  if (shape.size() != 2) {
    Fail(path, "expected a 2-D matrix, got " + std::to_string(shape.size()) + " dimension(s)");
  }
  result.rows = shape[0];
  result.cols = shape[1];
  if (result.rows != 0 && result.cols > kMaxNpyElements / result.rows) {
    Fail(path, "shape (" + std::to_string(shape[0]) + ", " + std::to_string(shape[1]) +
                   ") exceeds the limit of " + std::to_string(kMaxNpyElements) + " elements");
  }
  result.data_offset = header_start + header_len;
  const uint64_t need =
      static_cast<uint64_t>(result.rows * result.cols) * NpyDtypeBytes(result.dtype);
  const uint64_t have = bytes.size() - result.data_offset;
  if (have < need) {
    Fail(path, "header announces " + std::to_string(need) + " bytes of data but the file holds " +
                   std::to_string(have) + " (truncated file?)");
  }
  return result;
}

RowMatrixXf ReadNpyMatrix(const std::string& path) { return DecodeNpyMatrix(ReadFile(path), path); }

RowMatrixXf DecodeNpyMatrix(const std::string& bytes, const std::string& path) {
  const NpyHeader h = ParseNpyHeader(bytes, path);
  if (!IsFloatDtype(h.dtype)) {
    Fail(path, std::string("it holds ") + NpyDtypeName(h.dtype) + " ('" + NpyDtypeDescr(h.dtype) +
                   "') values; expected little-endian " + kFloatDtypes);
  }
  RowMatrixXf m(h.rows, h.cols);
  if (m.size() == 0) return m;  // no data to copy (and m.data() may be null)
  const char* data = bytes.data() + h.data_offset;
  switch (h.dtype) {
    case NpyDtype::kFloat32:
      if (!h.fortran_order) {
        std::memcpy(m.data(), data, static_cast<size_t>(m.size()) * 4);
      } else {
        DecodeRowMajor(data, h, Load<float>, m.data());
      }
      break;
    case NpyDtype::kFloat64:
      DecodeRowMajor(
          data, h, [](const char* p) { return static_cast<float>(Load<double>(p)); }, m.data());
      break;
    case NpyDtype::kFloat16:
      DecodeRowMajor(
          data, h, [](const char* p) { return HalfToFloat(Load<uint16_t>(p)); }, m.data());
      break;
    default:
      break;  // refused above
  }
  return m;
}

RowMatrixXb ReadNpyBoolMatrix(const std::string& path) {
  return DecodeNpyBoolMatrix(ReadFile(path), path);
}

RowMatrixXb DecodeNpyBoolMatrix(const std::string& bytes, const std::string& path) {
  const NpyHeader h = ParseNpyHeader(bytes, path);
  // 0 and 1 become false and true, every other value 2; the first 2 in row order is named.
  Eigen::Matrix<uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> truth(h.rows, h.cols);
  if (truth.size() == 0) return RowMatrixXb(h.rows, h.cols);
  const char* data = bytes.data() + h.data_offset;
  switch (h.dtype) {
    case NpyDtype::kFloat16:
      DecodeRowMajor(data, h, HalfTruthOf, truth.data());
      break;
    case NpyDtype::kFloat32:
      DecodeRowMajor(data, h, TruthOf<float>, truth.data());
      break;
    case NpyDtype::kFloat64:
      DecodeRowMajor(data, h, TruthOf<double>, truth.data());
      break;
    case NpyDtype::kBool:  // a byte; NumPy writes 0 or 1, anything else is no bool
    case NpyDtype::kUInt8:
      DecodeRowMajor(data, h, TruthOf<uint8_t>, truth.data());
      break;
    case NpyDtype::kInt8:
      DecodeRowMajor(data, h, TruthOf<int8_t>, truth.data());
      break;
    case NpyDtype::kInt16:
      DecodeRowMajor(data, h, TruthOf<int16_t>, truth.data());
      break;
    case NpyDtype::kUInt16:
      DecodeRowMajor(data, h, TruthOf<uint16_t>, truth.data());
      break;
    case NpyDtype::kInt32:
      DecodeRowMajor(data, h, TruthOf<int32_t>, truth.data());
      break;
    case NpyDtype::kUInt32:
      DecodeRowMajor(data, h, TruthOf<uint32_t>, truth.data());
      break;
    case NpyDtype::kInt64:
      DecodeRowMajor(data, h, TruthOf<int64_t>, truth.data());
      break;
    case NpyDtype::kUInt64:
      DecodeRowMajor(data, h, TruthOf<uint64_t>, truth.data());
      break;
  }
  const uint8_t* const begin = truth.data();
  const uint8_t* const bad = std::find(begin, begin + truth.size(), uint8_t{2});
  if (bad != begin + truth.size()) {
    const int64_t r = (bad - begin) / h.cols, c = (bad - begin) % h.cols;
    const int64_t k = h.fortran_order ? c * h.rows + r : r * h.cols + c;
    Fail(path, "row " + std::to_string(r) + ", column " + std::to_string(c) + " holds " +
                   ElementText(data + static_cast<size_t>(k) * NpyDtypeBytes(h.dtype), h.dtype) +
                   "; a truth matrix holds only 0 and 1 (or false and true)");
  }
  return truth.cast<bool>();
}

namespace {

// A version 1.0 header for a C-order matrix of `rows` x `cols` elements of `dtype`.
std::string NpyHeaderBytes(int64_t rows, int64_t cols, NpyDtype dtype) {
  std::string dict = std::string("{'descr': '") + NpyDtypeDescr(dtype) +
                     "', 'fortran_order': False, 'shape': (" + std::to_string(rows) + ", " +
                     std::to_string(cols) + "), }";
  // Pad with spaces so that the data starts at a multiple of 64 bytes, ending with '\n'.
  const size_t unpadded = 10 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict.push_back('\n');
  std::string out(kMagic, kMagicSize);
  out.push_back('\x01');
  out.push_back('\x00');
  out.push_back(static_cast<char>(dict.size() & 0xff));
  out.push_back(static_cast<char>((dict.size() >> 8) & 0xff));
  out += dict;
  return out;
}

}  // namespace

std::string EncodeNpyBytes(const void* data, int64_t rows, int64_t cols, NpyDtype dtype) {
  std::string out = NpyHeaderBytes(rows, cols, dtype);
  const size_t bytes = static_cast<size_t>(rows * cols) * NpyDtypeBytes(dtype);
  if (bytes > 0) out.append(static_cast<const char*>(data), bytes);
  return out;
}

std::string EncodeNpyMatrix(const RowMatrixXf& matrix, NpyDtype dtype) {
  if (!IsFloatDtype(dtype)) {
    throw std::invalid_argument(std::string("EncodeNpyMatrix writes float dtypes only, not ") +
                                NpyDtypeName(dtype));
  }
  std::string out = NpyHeaderBytes(matrix.rows(), matrix.cols(), dtype);
  const int64_t n = matrix.size();
  const size_t start = out.size();
  if (n == 0) return out;
  out.resize(start + static_cast<size_t>(n) * NpyDtypeBytes(dtype));
  char* dst = out.data() + start;
  for (int64_t i = 0; i < n; ++i) {
    const float v = matrix.data()[i];
    if (dtype == NpyDtype::kFloat32) {
      std::memcpy(dst + 4 * i, &v, 4);
    } else if (dtype == NpyDtype::kFloat64) {
      const double d = v;
      std::memcpy(dst + 8 * i, &d, 8);
    } else {
      const uint16_t bits = FloatToHalfOrInfinity(v);
      std::memcpy(dst + 2 * i, &bits, 2);
    }
  }
  return out;
}

void WriteNpyMatrix(const std::string& path, const RowMatrixXf& matrix, NpyDtype dtype) {
  WriteFileAtomically(path, EncodeNpyMatrix(matrix, dtype));
}

}  // namespace bsf_vpr
