#include <gtest/gtest.h>

#include <filesystem>

#include "bsf_vpr/core/file_util.h"
#include "test_util.h"

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

}  // namespace
}  // namespace bsf_vpr
