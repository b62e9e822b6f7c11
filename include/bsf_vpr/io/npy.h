// Reading and writing 2-D NumPy .npy matrices (format versions 1.0, 2.0 and 3.0).
//
// Accepted: exactly two dimensions, in C (row-major) or Fortran (column-major) order, of
// a little-endian dtype among float16 '<f2', float32 '<f4', float64 '<f8', bool '|b1' and
// the integers '|i1' '|u1' '<i2' '<u2' '<i4' '<u4' '<i8' '<u8' (one-byte types also as
// '<b1' '<i1' '<u1', as cnpy writes them). ReadNpyMatrix reads the float dtypes,
// ReadNpyBoolMatrix 0/1 matrices of any of them. NumPy writes Fortran order for a transposed
// array; such a file is transposed on decoding, so the result is always the row-major
// matrix of the header's shape. Anything else (other dtypes, big-endian data, 1-D or 3-D
// arrays, a header that claims more data than the file holds, sizes beyond kMaxNpyElements)
// is refused with std::runtime_error naming the file and the problem, before anything is
// allocated for the data.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

enum class NpyDtype {
  kFloat16,
  kFloat32,
  kFloat64,
  kBool,
  kInt8,
  kUInt8,
  kInt16,
  kUInt16,
  kInt32,
  kUInt32,
  kInt64,
  kUInt64,
};

// Largest number of elements accepted in one matrix (4 Gi floats = 16 GiB as float32).
constexpr int64_t kMaxNpyElements = int64_t{1} << 32;

// Bytes of one element of `dtype`.
size_t NpyDtypeBytes(NpyDtype dtype);
// True for float16, float32 and float64.
bool IsFloatDtype(NpyDtype dtype);
// NumPy's name of `dtype` and its descr string, e.g. "int32" and "<i4".
const char* NpyDtypeName(NpyDtype dtype);
const char* NpyDtypeDescr(NpyDtype dtype);

struct NpyHeader {
  NpyDtype dtype = NpyDtype::kFloat32;
  int64_t rows = 0;
  int64_t cols = 0;
  // Element (r, c) is the (r * cols + c)-th of the data in C order, the (c * rows + r)-th in
  // Fortran order.
  bool fortran_order = false;
  size_t data_offset = 0;  // bytes from the start of the file to the first element
};

// Parses and validates the header of an .npy file held in `bytes` (`path` is only used in
// messages). Also checks that `bytes` holds all the data the header announces.
NpyHeader ParseNpyHeader(std::string_view bytes, const std::string& path);

// Reads a 2-D float .npy matrix ('<f2', '<f4' or '<f8'; C or Fortran order) and converts
// it to float32. Other dtypes are refused. Throws std::runtime_error.
RowMatrixXf ReadNpyMatrix(const std::string& path);

// The same for a file's bytes already in memory (`path` only names it in messages).
RowMatrixXf DecodeNpyMatrix(const std::string& bytes, const std::string& path);

using RowMatrixXb = Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Reads a 2-D matrix of truth values: any accepted dtype (bool, integer or float; C or
// Fortran order) whose every element is 0 or 1 (0.0 or 1.0; -0.0 counts as 0). Throws
// std::runtime_error naming the file, the row and column of the first other value in row
// order, and that value.
RowMatrixXb ReadNpyBoolMatrix(const std::string& path);
RowMatrixXb DecodeNpyBoolMatrix(const std::string& bytes, const std::string& path);

// Serialises `matrix` as a version 1.0 .npy file (C order) in the given float dtype; throws
// std::invalid_argument for a dtype that is not a float.
std::string EncodeNpyMatrix(const RowMatrixXf& matrix, NpyDtype dtype = NpyDtype::kFloat32);

// Serialises rows already encoded (`rows` x `cols` elements of `dtype`, row-major, at
// `data`) as a version 1.0 .npy file (C order): an int8 or float16 set as it is held, so
// that it can be memory-mapped.
std::string EncodeNpyBytes(const void* data, int64_t rows, int64_t cols, NpyDtype dtype);

// Writes `matrix` to `path` atomically (temporary file + rename). Throws std::runtime_error
// (std::invalid_argument for a dtype that is not a float).
void WriteNpyMatrix(const std::string& path, const RowMatrixXf& matrix,
                    NpyDtype dtype = NpyDtype::kFloat32);

}  // namespace bsf_vpr
