// Reference sets in files (reference_set_io.h): the YAML sidecar and its .npy.
#include <gtest/gtest.h>

#include <filesystem>

#include "bsf_vpr/core/npy.h"
#include "bsf_vpr/core/reference_set_io.h"
#include "test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

class ReferenceSetIo : public testing::TempDirTest {};

TEST_F(ReferenceSetIo, ReferenceSetYamlRoundTrips) {
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

TEST_F(ReferenceSetIo, EmptyOrHugeShapesAreRefusedBeforeAllocatingAndNameTheFile) {
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

TEST_F(ReferenceSetIo, ReferenceSetYamlRefusesBadFilesNamingTheProblem) {
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
