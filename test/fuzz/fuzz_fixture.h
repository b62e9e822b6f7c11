// What the fuzz targets and their seed maker share: the small valid descriptor files that
// the reference-set YAML fuzzer writes next to each input, and a private temporary folder.
#pragma once

#include <stdlib.h>

#include <cstdio>
#include <stdexcept>
#include <string>

#include "bsf_vpr/core/types.h"
#include "bsf_vpr/io/npy.h"

namespace bsf_vpr {
namespace fuzz {

struct FixtureNpy {
  const char* file_name;
  int rows;
  int cols;
  NpyDtype dtype;
};

// a.npy: 4 places x 3 dimensions, float32; b.npy: 2 x 2, float16. Finite values. (A constant
// array, not a static vector: the fuzzers' exit handlers read it after static destructors.)
inline constexpr FixtureNpy kFixtureNpyFiles[] = {{"a.npy", 4, 3, NpyDtype::kFloat32},
                                                  {"b.npy", 2, 2, NpyDtype::kFloat16}};

inline RowMatrixXf FixtureMatrix(const FixtureNpy& f) {
  RowMatrixXf m(f.rows, f.cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = 0.25f * static_cast<float>(i + 1);
  return m;
}

// Writes every fixture .npy into `dir` (with the core's own writer).
inline void WriteFixtureNpyFiles(const std::string& dir) {
  for (const FixtureNpy& f : kFixtureNpyFiles) {
    WriteNpyMatrix(dir + "/" + f.file_name, FixtureMatrix(f), f.dtype);
  }
}

// A new private folder under $TMPDIR (or /tmp). Throws std::runtime_error.
inline std::string MakePrivateTempDir(const std::string& prefix) {
  const char* tmp = getenv("TMPDIR");
  std::string templ = std::string(tmp && *tmp ? tmp : "/tmp") + "/" + prefix + ".XXXXXX";
  if (mkdtemp(templ.data()) == nullptr) {
    throw std::runtime_error("cannot create a temporary folder '" + templ + "'");
  }
  return templ;
}

}  // namespace fuzz
}  // namespace bsf_vpr
