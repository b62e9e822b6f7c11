// Ground truth from files (ground_truth_io.h): CSV and .npy.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <tuple>

#include "bsf_vpr/evaluation/ground_truth_io.h"
#include "bsf_vpr/io/npy.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

class GroundTruthIo : public testing::TempDirTest {};

TEST_F(GroundTruthIo, GroundTruthNpyEqualsTheEquivalentCsv) {
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

TEST_F(GroundTruthIo, GroundTruthNpyOfTheWrongShapeOrValuesIsRefusedNamingTheProblem) {
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

std::string WriteTemp(const std::string& text) {
  char name[] = "/tmp/bsf_gt_XXXXXX";
  const int fd = mkstemp(name);
  close(fd);
  std::ofstream(name) << text;
  return name;
}

TEST(GroundTruthCsv, RoundTripsAndRefusesMalformedRows) {
  const GroundTruth t({{0, 1}, {}, {2}});
  const std::string path = WriteTemp("");
  WriteGroundTruthCsv(path, t);
  const GroundTruth back = ReadGroundTruthCsv(path, 3, 3);
  EXPECT_EQ(back.CorrectPlaces(0), (std::vector<int>{0, 1}));
  EXPECT_FALSE(back.HasTrueMatch(1));
  EXPECT_EQ(back.CorrectPlaces(2), (std::vector<int>{2}));
  std::remove(path.c_str());

  const std::vector<std::pair<std::string, std::string>> bad = {
      {"query,correct_places\n0 1 2\n", "line 2"},
      {"x,1\n", "not an integer"},
      {"0,1 zz\n", "'zz'"},
      {"7,1\n", "query 7"},
      {"0,9\n", "place 9"},
      {"0,1\n0,2\n", "twice"},
  };
  for (const auto& [text, expect] : bad) {
    const std::string p = WriteTemp(text);
    try {
      ReadGroundTruthCsv(p, 3, 3);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
    std::remove(p.c_str());
  }
  EXPECT_THROW(ReadGroundTruthCsv("/nonexistent/gt.csv", 3, 3), std::runtime_error);
}

}  // namespace
}  // namespace bsf_vpr
