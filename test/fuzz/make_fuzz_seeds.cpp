// Writes the seed corpora of the fuzz targets, made at run time from the core's own writer
// and the shipped data (so that no binary blobs are committed):
//
//   make_fuzz_seeds <repository folder> <npy seed folder> <yaml seed folder>
//
// .npy seeds: small valid matrices in every float dtype and format version and in Fortran
// order, truth matrices (0 and 1) in bool and integer dtypes, the shipped
// data/gardens_point_hdc_delf/day_left.npy cut short at several points, and headers that
// must be refused (1-D and 3-D shapes, other dtypes). YAML seeds: valid
// sidecars naming the fixture files of fuzz_fixture.h, and the shipped day_left.yaml
// pointed at one of them.
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "test/fuzz/fuzz_fixture.h"

namespace bsf_vpr {
namespace fuzz {
namespace {

void Write(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
}

// An .npy file from its header dictionary text and data, in format version 1, 2 or 3.
std::string MakeNpy(std::string dict, const std::string& data, int version) {
  const size_t prefix = version == 1 ? 10 : 12;
  dict.append((64 - (prefix + dict.size() + 1) % 64) % 64, ' ');
  dict.push_back('\n');
  std::string out("\x93NUMPY", 6);
  out.push_back(static_cast<char>(version));
  out.push_back('\0');
  const int len_bytes = version == 1 ? 2 : 4;
  for (int k = 0; k < len_bytes; ++k)
    out.push_back(static_cast<char>((dict.size() >> (8 * k)) & 0xff));
  return out + dict + data;
}

RowMatrixXf Ramp(int rows, int cols) {
  RowMatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = 0.5f * static_cast<float>(i) - 1.0f;
  return m;
}

void ReplaceAll(std::string& s, const std::string& from, const std::string& to) {
  for (size_t pos = s.find(from); pos != std::string::npos; pos = s.find(from, pos + to.size())) {
    s.replace(pos, from.size(), to);
  }
}

void WriteNpySeeds(const std::string& repo, const std::string& dir) {
  const struct {
    NpyDtype dtype;
    const char* name;
  } kDtypes[] = {
      {NpyDtype::kFloat16, "f2"}, {NpyDtype::kFloat32, "f4"}, {NpyDtype::kFloat64, "f8"}};
  for (const auto& d : kDtypes) {
    Write(dir + "/small_2x3_" + d.name + ".npy", EncodeNpyMatrix(Ramp(2, 3), d.dtype));
  }
  Write(dir + "/one_1x1.npy", EncodeNpyMatrix(Ramp(1, 1)));
  Write(dir + "/empty_0x3.npy", EncodeNpyMatrix(RowMatrixXf(0, 3)));
  Write(dir + "/empty_3x0.npy", EncodeNpyMatrix(RowMatrixXf(3, 0)));

  const std::string encoded_2x3 = EncodeNpyMatrix(Ramp(2, 3));
  const std::string data_2x3 = encoded_2x3.substr(ParseNpyHeader(encoded_2x3, "2x3").data_offset);
  const std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }";
  for (int version : {2, 3}) {
    Write(dir + "/version" + std::to_string(version) + ".npy", MakeNpy(dict, data_2x3, version));
  }
  std::string fortran = dict;
  ReplaceAll(fortran, "False", "True");
  Write(dir + "/fortran_2x3.npy", MakeNpy(fortran, data_2x3, 1));
  ReplaceAll(fortran, "(2, 3)", "(3, 2)");
  Write(dir + "/fortran_3x2.npy", MakeNpy(fortran, data_2x3, 1));
  std::string refused;
  const char* kBadShapes[] = {"(6,)", "(1, 2, 3)", "()", "(2, -3)"};
  for (size_t i = 0; i < sizeof(kBadShapes) / sizeof(kBadShapes[0]); ++i) {
    refused = dict;
    ReplaceAll(refused, "(2, 3)", kBadShapes[i]);
    Write(dir + "/shape" + std::to_string(i) + ".npy", MakeNpy(refused, data_2x3, 1));
  }
  for (const char* descr : {">f4", "<c8", ">i4"}) {
    refused = dict;
    ReplaceAll(refused, "<f4", descr);
    Write(dir + "/descr_" + std::string(descr + 1) + ".npy", MakeNpy(refused, data_2x3, 1));
  }
  // Truth matrices (0 and 1) in the bool and integer dtypes, in both orders.
  const struct {
    const char* descr;
    size_t bytes;
  } kTruthDtypes[] = {{"|b1", 1}, {"<b1", 1}, {"|u1", 1}, {"|i1", 1},
                      {"<i2", 2}, {"<u4", 4}, {"<i8", 8}, {"<u8", 8}};
  const int pattern_2x3[] = {1, 0, 0, 0, 1, 1};
  for (const auto& d : kTruthDtypes) {
    std::string data;
    for (int v : pattern_2x3) {
      data.push_back(static_cast<char>(v));
      data.append(d.bytes - 1, '\0');  // little-endian
    }
    std::string truth = dict;
    ReplaceAll(truth, "<f4", d.descr);
    const std::string name = dir + "/truth_" + std::string(d.descr + 1);
    Write(name + (d.descr[0] == '<' ? "_le" : "") + ".npy", MakeNpy(truth, data, 1));
    ReplaceAll(truth, "False", "True");
    Write(name + (d.descr[0] == '<' ? "_le" : "") + "_fortran.npy", MakeNpy(truth, data, 1));
  }

  // The shipped 200 x 4096 float32 matrix: cut short, and its corner re-encoded.
  const std::string shipped_path = repo + "/data/gardens_point_hdc_delf/day_left.npy";
  const std::string shipped = ReadFile(shipped_path);
  const NpyHeader h = ParseNpyHeader(shipped, shipped_path);
  Write(dir + "/day_left_9_bytes.npy", shipped.substr(0, 9));
  Write(dir + "/day_left_header.npy", shipped.substr(0, h.data_offset));
  Write(dir + "/day_left_header_and_256.npy", shipped.substr(0, h.data_offset + 256));
  const RowMatrixXf corner = ReadNpyMatrix(shipped_path).topLeftCorner(2, 8);
  for (const auto& d : kDtypes) {
    Write(dir + "/day_left_2x8_" + d.name + ".npy", EncodeNpyMatrix(corner, d.dtype));
  }
}

void WriteYamlSeeds(const std::string& repo, const std::string& dir) {
  Write(dir + "/minimal.yaml", "name: a\ndescriptors: a.npy\n");
  Write(dir + "/full.yaml",
        "name: winter\n"
        "condition: snow\n"
        "descriptor_type: patchnorm_64x32_p8\n"
        "dimension: 3\n"
        "distance: euclidean\n"
        "descriptors: a.npy\n"
        "place_ids: [0, 5, 2, 9]\n"
        "poses: [[0, 0, 0, 0], [1.5, 0, 0, 0.1], [3, 0.5, 0, -3.1], [4.5, 1, 0.2, 1e-3]]\n");
  Write(dir + "/flow.yaml", "{name: b, descriptors: b.npy, place_ids: [1, 0], distance: cosine}\n");
  Write(dir + "/block_lists.yaml",
        "name: b\ndescriptors: ./b.npy\nplace_ids:\n  - 7\n  - 3\nposes:\n  - [1, 2, 3, 4]\n"
        "  - [5, 6, 7, 8]\n");
  // Sets covering a few places of a larger map; the second id is far beyond the set's size.
  // (libFuzzer changes a number within its digits: the seeds bring the digits.)
  Write(dir + "/sparse_ids.yaml", "name: b\ndescriptors: b.npy\nplace_ids: [2500, 12]\n");
  Write(dir + "/far_ids.yaml", "name: b\ndescriptors: b.npy\nplace_ids: [12, 10000000]\n");
  Write(dir + "/unknown_key.yaml", "name: a\ndescriptors: a.npy\nplaces_ids: [0, 1, 2, 3]\n");
  Write(dir + "/wrong_dimension.yaml", "name: a\ndescriptors: a.npy\ndimension: 4\n");
  Write(dir + "/missing_npy.yaml", "name: c\ndescriptors: c.npy\n");
  // The fuzzer's folder as the images folder: its files stand in for images.
  Write(dir + "/images.yaml",
        "name: b\ndescriptors: b.npy\nimages: .\nimage_files: [a.npy, ./b.npy]\n");

  std::string shipped = ReadFile(repo + "/data/gardens_point_hdc_delf/day_left.yaml");
  ReplaceAll(shipped, "day_left.npy", kFixtureNpyFiles[0].file_name);
  ReplaceAll(shipped, "4096", std::to_string(kFixtureNpyFiles[0].cols));
  Write(dir + "/day_left.yaml", shipped);
}

}  // namespace
}  // namespace fuzz
}  // namespace bsf_vpr

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s <repository folder> <npy seed folder> <yaml seed folder>\n",
                 argv[0]);
    return 2;
  }
  try {
    bsf_vpr::fuzz::WriteNpySeeds(argv[1], argv[2]);
    bsf_vpr::fuzz::WriteYamlSeeds(argv[1], argv[3]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_fuzz_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
