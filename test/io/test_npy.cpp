// The .npy reader and writer (npy.h): float and truth matrices in every dtype and both
// orders, and what they refuse.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

class NpyIo : public testing::TempDirTest {
 protected:
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
};

TEST_F(NpyIo, NpyRoundTripsInEveryDtype) {
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

TEST_F(NpyIo, NpyInFortranOrderEqualsTheSameMatrixInCOrderInEveryDtype) {
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

TEST_F(NpyIo, ShippedGardensPointFilesLoadInFortranOrderAsNumPyWroteThem) {
  // data/gardens_point_hdc_delf holds the files as NumPy saved them, in Fortran order.
  const std::string shipped = BSF_SOURCE_DIR "/data/gardens_point_hdc_delf/day_left.npy";
  const std::string bytes = ReadFile(shipped);
  const NpyHeader h = ParseNpyHeader(bytes, shipped);
  ASSERT_TRUE(h.fortran_order) << shipped;
  const RowMatrixXf m = ReadNpyMatrix(shipped);
  ASSERT_EQ(m.rows(), 200);
  ASSERT_EQ(m.cols(), 4096);
  // Oracle: element (r, c) is float number c * rows + r of the data block.
  for (const auto& [r, c] : std::vector<std::pair<int, int>>{
           {0, 0}, {1, 0}, {0, 1}, {199, 4095}, {17, 2048}, {123, 7}}) {
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

TEST_F(NpyIo, NpyRefusesWhatItCannotRepresentWithAClearMessage) {
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

TEST_F(NpyIo, TruthMatricesAreReadFromEveryDtypeInBothOrders) {
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

TEST_F(NpyIo, TruthMatricesRefuseOtherValuesNamingTheFirstInRowOrder) {
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

}  // namespace
}  // namespace bsf_vpr
