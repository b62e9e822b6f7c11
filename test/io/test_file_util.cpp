#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

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

// A mapped file changed in place by another program says so; one truncated under the
// mapping turns to zeros where it was read (SIGBUS handled), and says it shrank; a file
// replaced by a rename keeps its old bytes and says nothing.
TEST_F(FileUtil, AMappedFileTellsWhenItWasChangedInPlaceAndATruncationEndsNothing) {
  const std::string page(4096, 'a');
  std::ofstream(Path("m.bin"), std::ios::binary) << page << page << page;
  std::shared_ptr<const MappedFile> m = MapFile(Path("m.bin"));
  ASSERT_EQ(m->size, 3 * 4096u);
  EXPECT_EQ(m->Changed(), "");
  // Replaced by a rename: the mapping keeps the old file, which did not change.
  WriteFileAtomically(Path("m.bin"), "new");
  EXPECT_EQ(m->Changed(), "");
  EXPECT_EQ(m->data[5000], 'a');

  std::ofstream(Path("w.bin"), std::ios::binary) << page << page;
  std::shared_ptr<const MappedFile> w = MapFile(Path("w.bin"));
  {
    std::fstream f(Path("w.bin"), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(100);
    f << "in place";
  }
  EXPECT_NE(w->Changed().find("rewritten in place"), std::string::npos) << w->Changed();
  EXPECT_NE(w->Changed().find("w.bin"), std::string::npos) << w->Changed();

  std::ofstream(Path("t.bin"), std::ios::binary) << page << page << page;
  std::shared_ptr<const MappedFile> t = MapFile(Path("t.bin"));
  EXPECT_EQ(t->data[0], 'a');  // touched before the truncation
  fs::resize_file(Path("t.bin"), 10);
  // Past the new end: the kernel's SIGBUS, handled; the pages read as zeros.
  volatile char past = t->data[2 * 4096 + 7];
  EXPECT_EQ(past, 0);
  EXPECT_NE(t->Changed().find("t.bin"), std::string::npos) << t->Changed();
  EXPECT_NE(t->Changed(), "");
  // A SIGBUS outside any mapping of ours is not swallowed: the process ends as it did.
  EXPECT_DEATH(
      {
        std::ofstream(Path("x.bin"), std::ios::binary) << page << page;
        const int fd = ::open(Path("x.bin").c_str(), O_RDONLY);
        const char* raw =
            static_cast<const char*>(::mmap(nullptr, 2 * 4096, PROT_READ, MAP_PRIVATE, fd, 0));
        fs::resize_file(Path("x.bin"), 10);
        volatile char c = raw[4096 + 1];
        (void)c;
      },
      "");
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
