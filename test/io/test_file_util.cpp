#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "bsf_vpr/io/file_util.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

class FileUtil : public testing::TempDirTest {};

TEST_F(FileUtil, AtomicWriteReplacesAndLeavesNoTemporaryFile) {
  WriteFileAtomically(Path("a.txt"), "one");
  WriteFileAtomically(Path("a.txt"), "two");
  EXPECT_EQ(ReadFile(Path("a.txt")), "two");
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir_)) entries += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(entries, 1);
  EXPECT_THROW(WriteFileAtomically(Path("no/such/dir/a.txt"), "x"), std::runtime_error);
}

TEST(ImageFileName, KnowsTheImageExtensionsInAnyCase) {
  for (const std::string name :
       {"a.png", "b.JPG", "c.jpeg", "d.Bmp", "e.pgm", "f.ppm", "x.y.png"}) {
    EXPECT_TRUE(IsImageFileName(name)) << name;
  }
  for (const std::string name : {"a.npy", "png", ".png", "a.png.txt", "a.tiff", "a.", ""}) {
    EXPECT_FALSE(IsImageFileName(name)) << name;
  }
}

TEST_F(FileUtil, ListImageFilesSortsTheImagesOfAFolder) {
  for (const std::string name : {"b.png", "a.JPG", "c.txt", "10.ppm", "2.pgm"}) {
    std::ofstream(Path(name)) << name;
  }
  fs::create_directory(Path("d.png"));                  // a folder, whatever its name
  fs::create_symlink(Path("b.png"), Path("link.png"));  // a link to an image is listed
  EXPECT_EQ(ListImageFiles(dir_),
            (std::vector<std::string>{Path("10.ppm"), Path("2.pgm"), Path("a.JPG"), Path("b.png"),
                                      Path("link.png")}));
  // ListImageFiles is ListFileNames' images: every regular file (or link to one) by name.
  EXPECT_EQ(ListFileNames(dir_),
            (std::vector<std::string>{"10.ppm", "2.pgm", "a.JPG", "b.png", "c.txt", "link.png"}));
  const auto refusal = [](const std::string& folder) {
    try {
      ListImageFiles(folder);
      return std::string("accepted");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
  };
  EXPECT_EQ(refusal(Path("none")), "'" + Path("none") + "' is not a folder");
  EXPECT_EQ(refusal(Path("b.png")), "'" + Path("b.png") + "' is not a folder");
  EXPECT_EQ(refusal(Path("d.png")), "folder '" + Path("d.png") + "' holds no image files");
}

}  // namespace
}  // namespace bsf_vpr
