#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <tuple>

#include "bsf_vpr/core/file_util.h"
#include "bsf_vpr/core/ground_truth_io.h"
#include "bsf_vpr/core/npy.h"
#include "bsf_vpr/core/reference_set_io.h"
#include "test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

class Files : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/bsf_files_XXXXXX";
    dir_ = mkdtemp(tmpl);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  void WriteRaw(const std::string& name, const std::string& bytes) const {
    std::ofstream(Path(name), std::ios::binary) << bytes;
  }
  // An .npy with a hand-written header dictionary and `data_bytes` bytes of data.
  std::string Npy(const std::string& dict, size_t data_bytes) const {
    return NpyWithData(dict, std::string(data_bytes, '\0'));
  }
  std::string NpyWithData(const std::string& dict, const std::string& data) const {
    return testing::NpyFile(dict, data);
  }
  void ExpectNpyError(const std::string& bytes, const std::string& fragment) {
    WriteRaw("bad.npy", bytes);
    try {
      ReadNpyMatrix(Path("bad.npy"));
      ADD_FAILURE() << "accepted a file that should fail with '" << fragment << "'";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.npy"), std::string::npos) << e.what();
    }
  }
  std::string dir_;
};

TEST_F(Files, NpyRoundTripsInEveryDtype) {
  const RowMatrixXf m = testing::RandomMatrix(17, 5, 3);
  for (NpyDtype t : {NpyDtype::kFloat32, NpyDtype::kFloat64, NpyDtype::kFloat16}) {
    WriteNpyMatrix(Path("m.npy"), m, t);
    const RowMatrixXf back = ReadNpyMatrix(Path("m.npy"));
    ASSERT_EQ(back.rows(), 17);
    ASSERT_EQ(back.cols(), 5);
    const float tol = t == NpyDtype::kFloat16 ? 4e-3f : 0.0f;
    EXPECT_TRUE(((back - m).array().abs() <= tol * (1 + m.array().abs())).all());
  }
  // numpy's own header layout (version 1.0) as written by numpy.save
  WriteRaw("np.npy", Npy("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 1), }", 8));
  EXPECT_EQ(ReadNpyMatrix(Path("np.npy")).rows(), 2);
}

// The bytes of `v` stored as `dtype` (little-endian, as on every machine this runs on).
std::string ElementBytes(float v, NpyDtype dtype) {
  std::string out(NpyDtypeBytes(dtype), '\0');
  if (dtype == NpyDtype::kFloat32) {
    std::memcpy(out.data(), &v, 4);
  } else if (dtype == NpyDtype::kFloat64) {
    const double d = v;
    std::memcpy(out.data(), &d, 8);
  } else {
    const uint16_t bits = Eigen::numext::bit_cast<uint16_t>(Eigen::half(v));
    std::memcpy(out.data(), &bits, 2);
  }
  return out;
}

TEST_F(Files, NpyInFortranOrderEqualsTheSameMatrixInCOrderInEveryDtype) {
  // Not square, so that a transposition that mixes up rows and columns cannot pass.
  const RowMatrixXf m = testing::RandomMatrix(3, 5, 11);
  const struct {
    NpyDtype dtype;
    const char* descr;
  } kDtypes[] = {
      {NpyDtype::kFloat16, "<f2"}, {NpyDtype::kFloat32, "<f4"}, {NpyDtype::kFloat64, "<f8"}};
  for (const auto& d : kDtypes) {
    // Column-major by hand: column 0 top to bottom, then column 1, ...
    std::string column_major;
    for (int c = 0; c < m.cols(); ++c) {
      for (int r = 0; r < m.rows(); ++r) column_major += ElementBytes(m(r, c), d.dtype);
    }
    const std::string dict =
        std::string("{'descr': '") + d.descr + "', 'fortran_order': True, 'shape': (3, 5), }";
    WriteRaw("f.npy", NpyWithData(dict, column_major));
    WriteRaw("c.npy", EncodeNpyMatrix(m, d.dtype));
    const RowMatrixXf fortran = ReadNpyMatrix(Path("f.npy"));
    const RowMatrixXf c_order = ReadNpyMatrix(Path("c.npy"));
    ASSERT_EQ(fortran.rows(), 3) << d.descr;
    ASSERT_EQ(fortran.cols(), 5) << d.descr;
    EXPECT_EQ(std::memcmp(fortran.data(), c_order.data(), sizeof(float) * 15), 0) << d.descr;
    const float tol = d.dtype == NpyDtype::kFloat16 ? 4e-3f : 0.0f;
    EXPECT_TRUE(((fortran - m).array().abs() <= tol * (1 + m.array().abs())).all()) << d.descr;
    EXPECT_TRUE(ParseNpyHeader(ReadFile(Path("f.npy")), "f.npy").fortran_order);
    // The checks of C order hold for Fortran order too: one byte short is a truncated file.
    ExpectNpyError(NpyWithData(dict, column_major.substr(1)), "truncated");
  }
  // Shapes with a zero, a single row and a single column, where the two orders coincide.
  WriteRaw("e.npy", Npy("{'descr': '<f4', 'fortran_order': True, 'shape': (0, 4), }", 0));
  EXPECT_EQ(ReadNpyMatrix(Path("e.npy")).cols(), 4);
  std::string row_data, col_data;
  for (int k = 0; k < 4; ++k) row_data += ElementBytes(static_cast<float>(k), NpyDtype::kFloat32);
  WriteRaw("r.npy",
           NpyWithData("{'descr': '<f4', 'fortran_order': True, 'shape': (1, 4), }", row_data));
  WriteRaw("v.npy",
           NpyWithData("{'descr': '<f4', 'fortran_order': True, 'shape': (4, 1), }", row_data));
  EXPECT_EQ(ReadNpyMatrix(Path("r.npy")), (RowMatrixXf(1, 4) << 0, 1, 2, 3).finished());
  EXPECT_EQ(ReadNpyMatrix(Path("v.npy")), (RowMatrixXf(4, 1) << 0, 1, 2, 3).finished());
  ExpectNpyError(Npy("{'descr': '<f4', 'fortran_order': True, 'shape': (100000, 100000), }", 16),
                 "exceeds the limit");
  ExpectNpyError(Npy("{'descr': '<f4', 'fortran_order': True, 'shape': (2, 2, 2), }", 32), "2-D");
}

TEST_F(Files, ShippedGardensPointFilesLoadInFortranOrderAsNumPyWroteThem) {
  // data/gardens_point_hdc_delf holds the files as NumPy saved them, in Fortran order.
  const std::string shipped = BSF_SOURCE_DIR "/data/gardens_point_hdc_delf/day_left.npy";
  const std::string bytes = ReadFile(shipped);
  const NpyHeader h = ParseNpyHeader(bytes, shipped);
  ASSERT_TRUE(h.fortran_order) << shipped;
  const RowMatrixXf m = ReadNpyMatrix(shipped);
  ASSERT_EQ(m.rows(), 200);
  ASSERT_EQ(m.cols(), 4096);
  // Oracle: element (r, c) is float number c * rows + r of the data block.
  for (const auto& [r, c] : std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {0, 1}, {199, 4095},
                                                             {17, 2048}, {123, 7}}) {
    float v;
    std::memcpy(&v, bytes.data() + h.data_offset + 4 * (static_cast<size_t>(c) * 200 + r), 4);
    EXPECT_EQ(m(r, c), v) << r << "," << c;
  }
  // The shared data (beside the repository in CI; reached through data/.. because the
  // catkin source folder is a folder of links into the repository) is the same file.
  const std::string shared =
      BSF_SOURCE_DIR "/data/../../shared/data/gardens_point_hdc_delf/day_left.npy";
  if (fs::exists(shared)) {
    EXPECT_EQ(ReadFile(shared), bytes);
  }
}

TEST_F(Files, NpyRefusesWhatItCannotRepresentWithAClearMessage) {
  // Integers and bools are truth matrices (ReadNpyBoolMatrix), not float matrices.
  ExpectNpyError(Npy("{'descr': '<i4', 'fortran_order': False, 'shape': (2, 2), }", 16),
                 "int32 ('<i4')");
  ExpectNpyError(Npy("{'descr': '|b1', 'fortran_order': False, 'shape': (2, 2), }", 4),
                 "bool ('|b1')");
  ExpectNpyError(Npy("{'descr': '<c8', 'fortran_order': False, 'shape': (2, 2), }", 32), "'<c8'");
  ExpectNpyError(Npy("{'descr': '>i4', 'fortran_order': False, 'shape': (2, 2), }", 16), "'>i4'");
  ExpectNpyError(Npy("{'descr': '>f4', 'fortran_order': False, 'shape': (2, 2), }", 16), "'>f4'");
  ExpectNpyError(Npy("{'descr': '<f4', 'fortran_order': False, 'shape': (4,), }", 16), "2-D");
  ExpectNpyError(Npy("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 2), }", 32), "2-D");
  ExpectNpyError(Npy("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2), }", 15),
                 "truncated");
  ExpectNpyError(Npy("{'descr': '<f4', 'fortran_order': False, 'shape': (100000, 100000), }", 16),
                 "exceeds the limit");
  ExpectNpyError(
      Npy("{'descr': '<f4', 'fortran_order': False, 'shape': (99999999999999999999, 1), }", 16),
      "absurdly large");
  ExpectNpyError(Npy("{'descr': '<f4', 'shape': (2, 2), }", 16), "fortran_order");
  ExpectNpyError("not an npy file at all", "magic");
  ExpectNpyError(std::string("\x93NUMPY\x01\x00\xff\x00{'descr'", 17), "truncated header");
  EXPECT_THROW(ReadNpyMatrix(Path("missing.npy")), std::runtime_error);
}

// `v` stored as the dtype `descr` names, written out by hand (little-endian).
std::string BytesAs(double v, const std::string& descr) {
  std::string out;
  auto put = [&out](auto x) {
    out.resize(sizeof(x));
    std::memcpy(out.data(), &x, sizeof(x));
  };
  const std::string type = descr.substr(1);
  if (type == "f2") put(Eigen::numext::bit_cast<uint16_t>(Eigen::half(static_cast<float>(v))));
  if (type == "f4") put(static_cast<float>(v));
  if (type == "f8") put(v);
  if (type == "b1" || type == "u1") put(static_cast<uint8_t>(v));
  if (type == "i1") put(static_cast<int8_t>(v));
  if (type == "i2") put(static_cast<int16_t>(v));
  if (type == "u2") put(static_cast<uint16_t>(v));
  if (type == "i4") put(static_cast<int32_t>(v));
  if (type == "u4") put(static_cast<uint32_t>(v));
  if (type == "i8") put(static_cast<int64_t>(v));
  if (type == "u8") put(static_cast<uint64_t>(v));
  if (out.empty()) ADD_FAILURE() << "BytesAs: unknown dtype " << descr;
  return out;
}

const char* const kTruthDtypes[] = {"|b1", "<b1", "|i1", "<i1", "|u1", "<u1", "<i2", "<u2",
                                    "<i4", "<u4", "<i8", "<u8", "<f2", "<f4", "<f8"};

TEST_F(Files, TruthMatricesAreReadFromEveryDtypeInBothOrders) {
  std::mt19937 rng(7);
  RowMatrixXb expected(4, 6);
  for (Eigen::Index i = 0; i < expected.size(); ++i) expected.data()[i] = rng() % 3 == 0;
  expected.row(2).setZero();  // a query without a true match
  for (const char* descr : kTruthDtypes) {
    for (const bool fortran : {false, true}) {
      std::string data;
      for (int k = 0; k < 24; ++k) {
        const int r = fortran ? k % 4 : k / 6, c = fortran ? k / 4 : k % 6;
        data += BytesAs(expected(r, c) ? 1.0 : 0.0, descr);
      }
      const std::string dict = std::string("{'descr': '") + descr +
                               "', 'fortran_order': " + (fortran ? "True" : "False") +
                               ", 'shape': (4, 6), }";
      WriteRaw("t.npy", NpyWithData(dict, data));
      EXPECT_EQ(ReadNpyBoolMatrix(Path("t.npy")), expected) << descr << " fortran " << fortran;
      WriteRaw("short.npy", NpyWithData(dict, data.substr(0, data.size() - 1)));
      EXPECT_THROW(ReadNpyBoolMatrix(Path("short.npy")), std::runtime_error) << descr;
    }
  }
  // -0.0 is 0.
  WriteRaw("z.npy", NpyWithData("{'descr': '<f4', 'fortran_order': False, 'shape': (1, 2), }",
                                BytesAs(-0.0, "<f4") + BytesAs(1.0, "<f4")));
  EXPECT_EQ(ReadNpyBoolMatrix(Path("z.npy")), (RowMatrixXb(1, 2) << false, true).finished());
  WriteRaw("e.npy", Npy("{'descr': '|b1', 'fortran_order': False, 'shape': (0, 3), }", 0));
  EXPECT_EQ(ReadNpyBoolMatrix(Path("e.npy")).cols(), 3);
}

TEST_F(Files, TruthMatricesRefuseOtherValuesNamingTheFirstInRowOrder) {
  // Other values at (1, 4) and (2, 0): (1, 4) comes first in row order, (2, 0) first in a
  // Fortran-order file.
  const std::vector<std::pair<std::string, std::pair<double, std::string>>> cases = {
      {"|b1", {2, "holds the byte 2"}}, {"|u1", {255, "holds 255"}},
      {"|i1", {-1, "holds -1"}},        {"<i8", {-5, "holds -5"}},
      {"<u8", {7, "holds 7"}},          {"<f2", {0.5, "holds 0.5"}},
      {"<f4", {1.5, "holds 1.5"}},      {"<f8", {std::nan(""), "holds nan"}},
  };
  for (const auto& [descr, bad] : cases) {
    for (const bool fortran : {false, true}) {
      std::string data;
      for (int k = 0; k < 15; ++k) {
        const int r = fortran ? k % 3 : k / 5, c = fortran ? k / 3 : k % 5;
        const bool is_bad = (r == 1 && c == 4) || (r == 2 && c == 0);
        data += BytesAs(is_bad ? bad.first : (r == c ? 1.0 : 0.0), descr);
      }
      WriteRaw("bad.npy", NpyWithData(std::string("{'descr': '") + descr + "', 'fortran_order': " +
                                          (fortran ? "True" : "False") + ", 'shape': (3, 5), }",
                                      data));
      try {
        ReadNpyBoolMatrix(Path("bad.npy"));
        ADD_FAILURE() << descr << " accepted";
      } catch (const std::runtime_error& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("bad.npy"), std::string::npos) << what;
        EXPECT_NE(what.find("row 1, column 4 " + bad.second), std::string::npos) << what;
      }
    }
  }
  EXPECT_THROW(EncodeNpyMatrix(RowMatrixXf(1, 1), NpyDtype::kBool), std::invalid_argument);
}

TEST_F(Files, GroundTruthNpyEqualsTheEquivalentCsv) {
  // 5 queries x 7 places at random, query 3 without a true match; the CSV lists the same.
  std::mt19937 rng(3);
  std::string csv = "query,correct_places\n", c_order, fortran(5 * 7, '\0');
  for (int q = 0; q < 5; ++q) {
    std::string places;
    for (int i = 0; i < 7; ++i) {
      const bool correct = q != 3 && rng() % 2 == 0;
      c_order.push_back(correct ? 1 : 0);
      fortran[static_cast<size_t>(i * 5 + q)] = correct ? 1 : 0;
      if (correct) places += (places.empty() ? "" : " ") + std::to_string(i);
    }
    if (!places.empty()) csv += std::to_string(q) + "," + places + "\n";
  }
  WriteRaw("gt.csv", csv);
  WriteRaw("gt.npy",
           NpyWithData("{'descr': '|b1', 'fortran_order': False, 'shape': (5, 7), }", c_order));
  WriteRaw("gt_f.npy",
           NpyWithData("{'descr': '|u1', 'fortran_order': True, 'shape': (5, 7), }", fortran));
  const GroundTruth expected = ReadGroundTruthCsv(Path("gt.csv"), 5, 7);
  EXPECT_FALSE(expected.HasTrueMatch(3));
  ASSERT_GT(expected.NumWithTrueMatch(), 2);
  for (const std::string name : {"gt.npy", "gt_f.npy", "gt.csv"}) {
    const GroundTruth t = ReadGroundTruthFile(Path(name), 5, 7);
    ASSERT_EQ(t.num_queries(), 5) << name;
    for (int q = 0; q < 5; ++q) EXPECT_EQ(t.CorrectPlaces(q), expected.CorrectPlaces(q)) << name;
  }
}

TEST_F(Files, GroundTruthNpyOfTheWrongShapeOrValuesIsRefusedNamingTheProblem) {
  WriteRaw("gt.npy", Npy("{'descr': '|b1', 'fortran_order': False, 'shape': (5, 7), }", 35));
  const std::vector<std::tuple<int, int, std::string>> cases = {
      {5, 8, "is 5 x 7 but the evaluation has 5 queries and 8 places"},
      {6, 7, "is 5 x 7 but the evaluation has 6 queries and 7 places"},
      {7, 5, "looks transposed"},
  };
  for (const auto& [queries, places, fragment] : cases) {
    try {
      ReadGroundTruthNpy(Path("gt.npy"), queries, places);
      ADD_FAILURE() << queries << " x " << places;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(Path("gt.npy")), std::string::npos) << e.what();
    }
  }
  // A header announcing gigabytes is refused from the header, before anything is allocated.
  WriteRaw("huge.npy",
           Npy("{'descr': '|b1', 'fortran_order': False, 'shape': (65536, 65536), }", 0));
  EXPECT_THROW(ReadGroundTruthNpy(Path("huge.npy"), 5, 7), std::runtime_error);
  std::string data(35, '\0');
  data[2 * 7 + 6] = 3;
  WriteRaw("three.npy",
           NpyWithData("{'descr': '<i1', 'fortran_order': False, 'shape': (5, 7), }", data));
  try {
    ReadGroundTruthFile(Path("three.npy"), 5, 7);
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("row 2, column 6 holds 3"), std::string::npos) << e.what();
  }
  // Float distances are no ground truth.
  WriteNpyMatrix(Path("d.npy"), testing::RandomMatrix(5, 7, 1));
  EXPECT_THROW(ReadGroundTruthFile(Path("d.npy"), 5, 7), std::runtime_error);
  EXPECT_THROW(ReadGroundTruthFile(Path("missing.npy"), 5, 7), std::runtime_error);
}

TEST_F(Files, AtomicWriteReplacesAndLeavesNoTemporaryFile) {
  WriteFileAtomically(Path("a.txt"), "one");
  WriteFileAtomically(Path("a.txt"), "two");
  EXPECT_EQ(ReadFile(Path("a.txt")), "two");
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir_)) entries += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(entries, 1);
  EXPECT_THROW(WriteFileAtomically(Path("no/such/dir/a.txt"), "x"), std::runtime_error);
}

TEST_F(Files, ReferenceSetYamlRoundTrips) {
  ReferenceSet s;
  s.name = "winter";
  s.condition = "snow";
  s.descriptor_type = "test_4";
  s.distance = "cosine";
  s.descriptors = testing::RandomMatrix(3, 4, 5);
  s.place_ids = {4, 0, 7};
  s.poses = {{1, 2, 3, 0.5}, {4, 5, 6, 0}, {7, 8, 9, -1}};
  SaveReferenceSet(s, Path("winter.yaml"));
  std::string npy;  // winter.<content hash>.npy, named by the YAML
  for (const auto& e : fs::directory_iterator(dir_)) {
    if (e.path().extension() == ".npy") npy = e.path().filename().string();
  }
  EXPECT_EQ(npy.rfind("winter.", 0), 0u) << npy;
  EXPECT_EQ(npy.size(), std::string("winter.0123456789ab.npy").size()) << npy;
  const ReferenceSet back = LoadReferenceSetFile(Path("winter.yaml"), "");
  EXPECT_EQ(back.name, "winter");
  EXPECT_EQ(back.condition, "snow");
  EXPECT_EQ(back.distance, "cosine");
  EXPECT_EQ(back.place_ids, s.place_ids);
  ASSERT_EQ(back.poses.size(), 3u);
  EXPECT_DOUBLE_EQ(back.poses[2].y_m, 8);
  EXPECT_TRUE(back.descriptors.isApprox(s.descriptors));
  EXPECT_EQ(LoadReferenceSetFile(Path(npy), "w2").name, "w2");
}

TEST_F(Files, EmptyOrHugeShapesAreRefusedBeforeAllocatingAndNameTheFile) {
  // Tiny files whose shapes would have allocated gigabytes of place ids.
  for (const std::string shape : {"(1000000000, 0)", "(4294967296, 0)", "(0, 5)"}) {
    WriteRaw("e.npy", Npy("{'descr': '<f4', 'fortran_order': False, 'shape': " + shape + ", }", 0));
    try {
      LoadReferenceSetNpy(Path("e.npy"), "e");
      ADD_FAILURE() << shape;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("e.npy"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("no descriptors"), std::string::npos) << e.what();
    }
  }
  // An empty matrix still round-trips through the generic reader and writer.
  WriteNpyMatrix(Path("z.npy"), RowMatrixXf(0, 3));
  EXPECT_EQ(ReadNpyMatrix(Path("z.npy")).cols(), 3);
  // A missing file is called missing, whatever its extension.
  try {
    LoadReferenceSetFile(Path("missing.txt"), "m");
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
}

TEST_F(Files, ReferenceSetYamlRefusesBadFilesNamingTheProblem) {
  WriteNpyMatrix(Path("d.npy"), testing::RandomMatrix(3, 4, 5));
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"name: a\ndescriptors: d.npy\ncondtion: snow\n", "unknown key 'condtion'"},
      {"descriptors: d.npy\n", "'name'"},
      {"name: a\n", "'descriptors'"},
      {"name: a\ndescriptors: d.npy\ndimension: 5\n", "dimension 5"},
      {"name: a\ndescriptors: d.npy\nplace_ids: [0, 1]\n", "2 place_ids"},
      {"name: a\ndescriptors: d.npy\nplace_ids: [0, 1, 1]\n", "two descriptors for place 1"},
      {"name: a\ndescriptors: d.npy\nposes: [[0, 0, 0]]\n", "[x, y, z, yaw]"},
      {"name: a\ndescriptors: d.npy\ndistance: hamming\n", "hamming"},
      {"name: a\ndescriptors: gone.npy\n", "gone.npy"},
      {"[1, 2", "bad.yaml"},
  };
  for (const auto& [text, expect] : bad) {
    WriteRaw("bad.yaml", text);
    try {
      LoadReferenceSetFile(Path("bad.yaml"), "");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(LoadReferenceSetFile(Path("d.txt"), "x"), std::runtime_error);
  EXPECT_THROW(LoadReferenceSetYaml(Path("none.yaml")), std::runtime_error);
}

}  // namespace
}  // namespace bsf_vpr
