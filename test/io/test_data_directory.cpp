// DataDirectory (confined reads and writes) and the atomic save of a reference set.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

class DataDir : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/bsf_datadir_XXXXXX";
    root_ = mkdtemp(tmpl);
    fs::create_directories(root_ + "/data/sets");
    fs::create_directories(root_ + "/outside");
    Write(root_ + "/outside/secret.txt", "secret");
    WriteNpyMatrix(root_ + "/outside/o.npy", testing::RandomMatrix(4, 3, 1));
    dir_ = std::make_unique<DataDirectory>(root_ + "/data");
  }
  void TearDown() override { fs::remove_all(root_); }
  static void Write(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
  }
  static std::string Slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  std::string Data(const std::string& rel) const { return root_ + "/data/" + rel; }
  // Every regular file below root/outside with its content: nothing may change there.
  std::map<std::string, std::string> Outside() const {
    std::map<std::string, std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(root_ + "/outside")) {
      if (e.is_regular_file()) out[e.path().string()] = Slurp(e.path().string());
    }
    return out;
  }

  std::string root_;
  std::unique_ptr<DataDirectory> dir_;
};

TEST_F(DataDir, RelativeNormalisesAndRefusesEscapes) {
  EXPECT_EQ(dir_->Relative("sets/a.yaml"), "sets/a.yaml");
  EXPECT_EQ(dir_->Relative("./sets//x/../a.yaml"), "sets/a.yaml");
  EXPECT_EQ(dir_->Relative(dir_->path() + "/sets/a.yaml"), "sets/a.yaml");
  for (const std::string bad :
       {"", "..", "../outside/secret.txt", "sets/../../outside/o.npy", "/etc/passwd", ".",
        "sets/..", "a\nb.yaml", "bad\xff.yaml", "tab\t.yaml"}) {
    EXPECT_THROW(dir_->Relative(bad), std::invalid_argument) << bad;
  }
  // Another folder whose name starts with the data directory's.
  EXPECT_THROW(dir_->Relative(dir_->path() + "x/a.yaml"), std::invalid_argument);
}

TEST_F(DataDir, ReadsOnlyRegularFilesBelowWithoutFollowingLinks) {
  Write(Data("sets/a.txt"), "inside");
  EXPECT_EQ(dir_->Read("sets/a.txt"), "inside");
  fs::create_symlink(root_ + "/outside/secret.txt", Data("link.txt"));
  fs::create_directory_symlink(root_ + "/outside", Data("outlink"));
  fs::create_symlink("/dev/zero", Data("zero.npy"));
  ASSERT_EQ(mkfifo(Data("fifo.npy").c_str(), 0644), 0);
  for (const std::string bad : {"link.txt", "outlink/secret.txt", "zero.npy", "sets", "missing"}) {
    EXPECT_THROW(dir_->Read(bad), std::runtime_error) << bad;
  }
  // A FIFO is refused at once instead of blocking the reader.
  const auto start = std::chrono::steady_clock::now();
  try {
    dir_->Read("fifo.npy");
    ADD_FAILURE() << "read a FIFO";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  // The unconfined reader refuses FIFOs and devices too.
  EXPECT_THROW(ReadFile(Data("fifo.npy")), std::runtime_error);
  EXPECT_THROW(ReadFile("/dev/zero"), std::runtime_error);
}

TEST_F(DataDir, WritesAtomicallyBelowAndNeverThroughALink) {
  const auto before = Outside();
  dir_->WriteAtomically("new/deeper/a.txt", "one");  // folders are made
  EXPECT_EQ(Slurp(Data("new/deeper/a.txt")), "one");
  dir_->WriteAtomically("new/deeper/a.txt", "two");
  EXPECT_EQ(Slurp(Data("new/deeper/a.txt")), "two");
  EXPECT_THROW(dir_->WriteAtomically("new/deeper/a.txt", "three", /*replace=*/false),
               std::runtime_error);
  EXPECT_EQ(Slurp(Data("new/deeper/a.txt")), "two");
  // A link swapped in where the file goes is replaced as a link, its target untouched.
  fs::create_symlink(root_ + "/outside/secret.txt", Data("swap.yaml"));
  EXPECT_THROW(dir_->WriteAtomically("swap.yaml", "x", /*replace=*/false), std::runtime_error);
  dir_->WriteAtomically("swap.yaml", "mine");
  EXPECT_FALSE(fs::is_symlink(Data("swap.yaml")));
  // A link where a folder is on the way is refused.
  fs::create_directory_symlink(root_ + "/outside", Data("via"));
  EXPECT_THROW(dir_->WriteAtomically("via/evil.txt", "x"), std::runtime_error);
  EXPECT_THROW(dir_->WriteAtomically("../outside/evil.txt", "x"), std::invalid_argument);
  EXPECT_EQ(Outside(), before);
  // A file where a folder should be makes the write fail with its reason.
  Write(Data("blocker"), "");
  EXPECT_THROW(dir_->WriteAtomically("blocker/a.txt", "x"), std::runtime_error);
  // No temporary is left behind by any of this.
  for (const auto& e : fs::recursive_directory_iterator(root_ + "/data")) {
    EXPECT_EQ(e.path().filename().string().find(".bsf_tmp."), std::string::npos) << e.path();
  }
}

TEST_F(DataDir, ListsTemporariesOfItsOwnFormAndRemovesNone) {
  Write(Data(".a.yaml.bsf_tmp.abcdefgh"), "half");
  Write(Data("sets/.b.npy.bsf_tmp.12345678"), "half");
  Write(Data("sets/keep.yaml"), "name: keep");
  // Named like one but not of the form: a person's files.
  Write(Data(".mine.bsf_tmp.keep"), "mine");
  Write(Data(".c.npy.bsf_tmp.ABCDEFGH"), "mine");
  Write(Data("d.npy.bsf_tmp.abcdefgh"), "mine");
  EXPECT_EQ(dir_->Temporaries(),
            (std::vector<std::string>{".a.yaml.bsf_tmp.abcdefgh", "sets/.b.npy.bsf_tmp.12345678"}));
  for (const char* f : {".a.yaml.bsf_tmp.abcdefgh", "sets/.b.npy.bsf_tmp.12345678",
                        ".mine.bsf_tmp.keep", ".c.npy.bsf_tmp.ABCDEFGH", "d.npy.bsf_tmp.abcdefgh"}) {
    EXPECT_TRUE(fs::exists(Data(f))) << f;
  }
  EXPECT_TRUE(DataDirectory::IsTemporaryOf(".a.yaml.bsf_tmp.abcdefgh", "a.yaml"));
  EXPECT_TRUE(DataDirectory::IsTemporaryOf("sets/.b.npy.bsf_tmp.12345678", "sets/b.npy"));
  EXPECT_FALSE(DataDirectory::IsTemporaryOf("sets/.b.npy.bsf_tmp.12345678", "b.npy"));
  EXPECT_FALSE(DataDirectory::IsTemporaryOf(".a.yaml.bsf_tmp.abcdefgh", "b.yaml"));
  EXPECT_FALSE(DataDirectory::IsTemporaryOf(".mine.bsf_tmp.keep", "mine"));
}

TEST_F(DataDir, ListsTheRegularFilesBelowItWithoutFollowingLinks) {
  Write(Data("b.yaml"), "");
  fs::create_directories(Data("sets/night"));
  Write(Data("sets/night/a.npy"), "");
  Write(Data("sets/.hidden"), "");
  fs::create_directories(Data("empty"));
  fs::create_symlink(Data("b.yaml"), Data("link.yaml"));
  fs::create_directory_symlink(root_ + "/outside", Data("out"));
  EXPECT_EQ(dir_->ListFilesBelow(),
            (std::vector<std::string>{"b.yaml", "sets/.hidden", "sets/night/a.npy"}));
}

TEST_F(DataDir, ReferenceSetYamlCannotReachOutside) {
  const auto bad = [&](const std::string& field) {
    Write(Data("bad.yaml"), "name: bad\ndescriptors: " + field + "\n");
    EXPECT_THROW(LoadReferenceSetFile(*dir_, "bad.yaml", ""), std::exception) << field;
  };
  bad(root_ + "/outside/o.npy");  // absolute, outside
  bad("../outside/o.npy");
  bad("sets/../../outside/o.npy");
  fs::create_symlink(root_ + "/outside/o.npy", Data("l.npy"));
  bad("l.npy");
  bad("/dev/zero");
  // The same YAML is fine when its descriptors lie below the directory.
  WriteNpyMatrix(Data("sets/d.npy"), testing::RandomMatrix(4, 3, 2));
  Write(Data("sets/good.yaml"), "name: good\ndescriptors: d.npy\n");
  EXPECT_EQ(LoadReferenceSetFile(*dir_, "sets/good.yaml", "").size(), 4);
  Write(Data("abs.yaml"), "name: abs\ndescriptors: " + dir_->path() + "/sets/d.npy\n");
  EXPECT_EQ(LoadReferenceSetFile(*dir_, "abs.yaml", "").size(), 4);
}

TEST_F(DataDir, SavingReplacesTheYamlAndNpyPairAsOne) {
  ReferenceSet a = MakeReferenceSet("route", testing::RandomMatrix(5, 3, 3));
  SaveReferenceSet(*dir_, a, "route.yaml", /*replace=*/false);
  const std::string first_npy = LoadReferenceSetYaml(Data("route.yaml")).name;
  EXPECT_EQ(first_npy, "route");
  EXPECT_THROW(SaveReferenceSet(*dir_, a, "route.yaml", /*replace=*/false), std::invalid_argument);

  // A save interrupted after its .npy was written (before the YAML's rename) leaves the old
  // pair whole: the YAML still names the old descriptors, which are still there.
  ReferenceSet b = MakeReferenceSet("route", testing::RandomMatrix(7, 3, 4));
  dir_->WriteAtomically("route.0123456789ab.npy", EncodeNpyMatrix(b.descriptors));
  EXPECT_TRUE(LoadReferenceSetFile(*dir_, "route.yaml", "").descriptors.isApprox(a.descriptors));

  // A finished save: the new pair, and the old descriptors file is gone.
  SaveReferenceSet(*dir_, b, "route.yaml", /*replace=*/true);
  EXPECT_TRUE(LoadReferenceSetFile(*dir_, "route.yaml", "").descriptors.isApprox(b.descriptors));
  int npys = 0;
  for (const auto& e : fs::directory_iterator(root_ + "/data")) {
    npys += e.path().extension() == ".npy" && e.path().filename() != "route.0123456789ab.npy";
  }
  EXPECT_EQ(npys, 1);

  // A save that cannot write keeps the old pair.
  Write(Data("blocked"), "");
  EXPECT_THROW(SaveReferenceSet(*dir_, b, "blocked/x.yaml", true), std::runtime_error);
  EXPECT_TRUE(LoadReferenceSetFile(*dir_, "route.yaml", "").descriptors.isApprox(b.descriptors));
}

TEST_F(DataDir, ListsTheRegularFilesOfAFolderWithoutFollowingLinks) {
  fs::create_directories(Data("sets/imgs/sub"));
  for (const std::string name : {"b.png", "a.png", "c.txt"}) Write(Data("sets/imgs/" + name), name);
  fs::create_symlink(Data("sets/imgs/a.png"), Data("sets/imgs/inside_link.png"));
  fs::create_symlink(root_ + "/outside/secret.txt", Data("sets/imgs/outside_link.png"));
  ASSERT_EQ(mkfifo(Data("sets/imgs/fifo.png").c_str(), 0644), 0);
  EXPECT_EQ(dir_->ListFiles("sets/imgs"), (std::vector<std::string>{"a.png", "b.png", "c.txt"}));
  EXPECT_EQ(dir_->ListFiles(dir_->path() + "/sets/imgs/"), dir_->ListFiles("sets/imgs"));
  EXPECT_TRUE(dir_->ListFiles("sets/imgs/sub").empty());
  const auto refusal = [&](const std::string& folder) {
    try {
      dir_->ListFiles(folder);
      return std::string("accepted");
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  };
  // A folder reached through a link, at the end or on the way, is refused.
  fs::create_directory_symlink(root_ + "/outside", Data("outlink"));
  fs::create_directory_symlink(Data("sets"), Data("inlink"));
  EXPECT_NE(refusal("outlink").find("links are not followed"), std::string::npos);
  EXPECT_NE(refusal("inlink/imgs").find("links are not followed"), std::string::npos);
  EXPECT_NE(refusal("sets/none").find("No such file"), std::string::npos);
  EXPECT_EQ(refusal("sets/imgs/a.png"), "'sets/imgs/a.png' is not a folder");
  EXPECT_NE(refusal("../outside").find("outside the data directory"), std::string::npos);
  EXPECT_NE(refusal(root_ + "/outside").find("outside the data directory"), std::string::npos);
}

// A folder of image files below the data directory (any content: only bytes matter here).
void MakeImages(const std::string& folder, const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    fs::create_directories(fs::path(folder + "/" + name).parent_path());
    std::ofstream(folder + "/" + name) << "image " << name;
  }
}

// The error that loading `yaml` (below the data directory) gives: read through `dir`, or
// unconfined when dir is null.
std::string Refusal(const DataDirectory* dir, const std::string& yaml) {
  try {
    if (dir) {
      LoadReferenceSetFile(*dir, yaml, "");
    } else {
      LoadReferenceSetFile(yaml, "");
    }
    return "accepted";
  } catch (const std::exception& e) {
    return e.what();
  }
}

TEST_F(DataDir, ImagesFollowTheSameRulesInBothAccessModes) {
  WriteNpyMatrix(Data("sets/d.npy"), testing::RandomMatrix(3, 4, 5));
  MakeImages(Data("sets/imgs"), {"a.png", "b.png", "c.png", "d.png", "sub/x.png"});
  MakeImages(Data("sets/three"), {"c.png", "a.png", "b.png", "notes.txt"});
  Write(Data("sets/file.png"), "");
  const std::string head = "name: s\ndescriptors: d.npy\n";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"images: imgs\n",
       "images: 'imgs' holds 4 image files for 3 descriptors; list each row's file with "
       "image_files"},
      {"images: nowhere\n", "nowhere"},
      {"images: file.png\n", "is not a folder"},
      {"images: nowhere\nimage_files: [a.png, b.png, c.png]\n", "nowhere"},
      {"image_files: [a.png, b.png, c.png]\n", "'image_files' needs 'images'"},
      {"images: imgs\nimage_files: [a.png, b.png]\n", "'image_files' lists 2 files for 3"},
      {"images: imgs\nimage_files: [a.png, /etc/passwd, c.png]\n",
       "image_files[1] '/etc/passwd' is absolute"},
      {"images: imgs\nimage_files: [a.png, b.png, ../three/a.png]\n",
       "image_files[2] '../three/a.png' has a '..' part"},
      {"images: imgs\nimage_files: [a.png, gone.png, c.png]\n",
       "image_files[1] 'gone.png' is not a file in images 'imgs'"},
      {"images: imgs\nimage_files: [a.png, b.png, nosub/x.png]\n",
       "image_files[2] 'nosub/x.png' is not a file in images 'imgs'"},
  };
  for (const DataDirectory* dir : std::vector<const DataDirectory*>{dir_.get(), nullptr}) {
    const std::string yaml = dir ? "sets/s.yaml" : Data("sets/s.yaml");
    for (const auto& [text, fragment] : bad) {
      Write(Data("sets/s.yaml"), head + text);
      const std::string why = Refusal(dir, yaml);
      EXPECT_NE(why.find("reference set file '" + yaml + "': "), std::string::npos) << why;
      EXPECT_NE(why.find(fragment), std::string::npos) << (dir ? "confined " : "") << text << why;
    }
    // What is right loads alike, `images` absolute: row k is the k-th image by name.
    Write(Data("sets/s.yaml"), head + "images: three\n");
    ReferenceSet s = dir ? LoadReferenceSetFile(*dir, yaml, "") : LoadReferenceSetFile(yaml, "");
    EXPECT_EQ(s.images, dir_->path() + "/sets/three");
    EXPECT_EQ(s.image_files, (std::vector<std::string>{"a.png", "b.png", "c.png"}));
    Write(Data("sets/s.yaml"), head + "images: " + dir_->path() + "/sets/imgs\n" +
                                   "image_files: [d.png, sub/x.png, a.png]\n");
    s = dir ? LoadReferenceSetFile(*dir, yaml, "") : LoadReferenceSetFile(yaml, "");
    EXPECT_EQ(s.images, dir_->path() + "/sets/imgs");
    EXPECT_EQ(s.image_files, (std::vector<std::string>{"d.png", "sub/x.png", "a.png"}));
  }
}

TEST_F(DataDir, ImagesOutsideTheDataDirectoryAreNotRead) {
  WriteNpyMatrix(Data("sets/d.npy"), testing::RandomMatrix(2, 4, 5));
  MakeImages(root_ + "/outside/imgs", {"a.png", "b.png"});
  MakeImages(Data("sets/imgs"), {"a.png"});
  fs::create_symlink(root_ + "/outside/imgs/b.png", Data("sets/imgs/b.png"));
  fs::create_directory_symlink(root_ + "/outside/imgs", Data("sets/outlink"));
  const std::string head = "name: s\ndescriptors: d.npy\n";
  // Images outside the data directory are not read: the set loads without them (bsf_import
  // writes its YAML into the data directory and names the dataset's frames).
  for (const std::string& outside : std::vector<std::string>{
           "images: ../../outside/imgs\n", "images: " + root_ + "/outside/imgs\n"}) {
    Write(Data("sets/s.yaml"), head + outside);
    const ReferenceSet set = LoadReferenceSetFile(*dir_, "sets/s.yaml", "");
    EXPECT_EQ(set.size(), 2) << outside;
    EXPECT_TRUE(set.images.empty()) << outside;
    EXPECT_TRUE(set.image_files.empty()) << outside;
  }
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"images: outlink\n", "links are not followed below the data directory"},
      {"images: outlink\nimage_files: [a.png, b.png]\n", "links are not followed"},
      // A link among the images is no image of the set: one image for two rows.
      {"images: imgs\nimage_files: [a.png, b.png]\n", "image_files[1] 'b.png' is not a file"},
  };
  for (const auto& [text, fragment] : bad) {
    Write(Data("sets/s.yaml"), head + text);
    const std::string why = Refusal(dir_.get(), "sets/s.yaml");
    EXPECT_NE(why.find(fragment), std::string::npos) << text << why;
  }
  Write(Data("sets/s.yaml"), head + "images: imgs\n");
  EXPECT_NE(Refusal(dir_.get(), "sets/s.yaml").find("holds 1 image files for 2 descriptors"),
            std::string::npos);
  // Unconfined (the operator's own files), the same YAML follows the links.
  EXPECT_EQ(LoadReferenceSetFile(Data("sets/s.yaml"), "").image_files,
            (std::vector<std::string>{"a.png", "b.png"}));
}

// A reference set's YAML may name any file as an image: one larger than the limit (here a
// sparse 1 GiB file, which takes no disk) is refused before a byte of it is read, through
// the data directory and outside it, naming the set, the row and the sizes.
TEST_F(DataDir, RefusesAReferenceImageLargerThanTheLimitBeforeReadingIt) {
  WriteNpyMatrix(Data("sets/d.npy"), testing::RandomMatrix(2, 4, 5));
  MakeImages(Data("sets/imgs"), {"a.png", "b.png"});
  const std::string huge = Data("sets/imgs/b.png");
  ASSERT_EQ(truncate(huge.c_str(), off_t{1} << 30), 0);
  Write(Data("sets/s.yaml"), "name: s\ndescriptors: d.npy\nimages: imgs\n");
  ReferenceSets map;
  map.Add(LoadReferenceSetFile(*dir_, "sets/s.yaml", ""));
  const uint64_t limit = 20u << 20;
  EXPECT_EQ(ReadReferenceImage(map.set(0), 0, dir_.get(), limit), "image a.png");
  for (const DataDirectory* dir : {static_cast<const DataDirectory*>(dir_.get()),
                                   static_cast<const DataDirectory*>(nullptr)}) {
    try {
      ReadReferenceImage(map.set(0), 1, dir, limit);
      ADD_FAILURE() << "read a file over the limit";
    } catch (const std::runtime_error& e) {
      const std::string why = e.what();
      EXPECT_NE(why.find("reference set 's' row 1: "), std::string::npos) << why;
      EXPECT_NE(why.find("b.png' is 1073741824 bytes, more than the 20971520 allowed"),
                std::string::npos)
          << why;
    }
  }
  EXPECT_THROW(ReadFile(huge, 1000), std::runtime_error);
  EXPECT_EQ(ReadFile(Data("sets/imgs/a.png"), 11), "image a.png");  // the limit is allowed
}

TEST_F(DataDir, ReadsReferenceImagesThroughTheDataDirectoryWhenTheyLieBelowIt) {
  WriteNpyMatrix(Data("sets/d.npy"), testing::RandomMatrix(2, 4, 5));
  MakeImages(Data("sets/imgs"), {"a.png", "b.png"});
  Write(Data("sets/s.yaml"), "name: s\ndescriptors: d.npy\nimages: imgs\n");
  ReferenceSets map;  // the sets as the node holds them
  map.Add(LoadReferenceSetFile(*dir_, "sets/s.yaml", ""));
  const StoredReferenceSet& set = map.set(0);
  ReferenceSets others;  // adding to `map` could move the set `set` refers to
  EXPECT_EQ(ReadReferenceImage(set, 1, dir_.get()), "image b.png");
  EXPECT_EQ(ReadReferenceImage(set, 0, nullptr), "image a.png");
  // A link swapped in below the data directory after loading is refused through it, and
  // named; without a data directory (the operator's own files) it is followed.
  fs::remove(Data("sets/imgs/b.png"));
  fs::create_symlink(root_ + "/outside/secret.txt", Data("sets/imgs/b.png"));
  try {
    ReadReferenceImage(set, 1, dir_.get());
    ADD_FAILURE() << "read through a link";
  } catch (const std::runtime_error& e) {
    const std::string why = e.what();
    EXPECT_NE(why.find("reference set 's' row 1: cannot open 'sets/imgs/b.png'"), std::string::npos)
        << why;
    EXPECT_NE(why.find("links are not followed"), std::string::npos) << why;
  }
  EXPECT_EQ(ReadReferenceImage(set, 1, nullptr), "secret");
  // Images outside the data directory (a set the operator configured) are read as files.
  MakeImages(root_ + "/outside/imgs", {"x.png", "y.png"});
  ReferenceSet outside = MakeReferenceSet("o", testing::RandomMatrix(2, 4, 6));
  outside.images = root_ + "/outside/imgs";
  outside.image_files = {"y.png", "x.png"};
  others.Add(outside);
  EXPECT_EQ(ReadReferenceImage(others.set(0), 0, dir_.get()), "image y.png");
  EXPECT_EQ(ReadReferenceImage(others.set(0), 1, nullptr), "image x.png");
  fs::remove(root_ + "/outside/imgs/x.png");
  try {
    ReadReferenceImage(others.set(0), 1, dir_.get());
    ADD_FAILURE() << "read a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("reference set 'o' row 1: cannot open '" + root_ +
                                         "/outside/imgs/x.png': No such file"),
              std::string::npos)
        << e.what();
  }
  // Bad rows and sets without images are the caller's mistake.
  EXPECT_THROW(ReadReferenceImage(set, 2, dir_.get()), std::invalid_argument);
  EXPECT_THROW(ReadReferenceImage(set, -1, nullptr), std::invalid_argument);
  others.Add(MakeReferenceSet("plain", testing::RandomMatrix(2, 4, 7)));
  try {
    ReadReferenceImage(others.set(1), 0, dir_.get());
    ADD_FAILURE() << "a set without images gave an image";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'plain' names no images"), std::string::npos);
  }
}

TEST_F(DataDir, SavedImagesBelowTheDataDirectoryRoundTrip) {
  MakeImages(Data("images/winter"), {"0.png", "1.png", "2.png"});
  ReferenceSet s = MakeReferenceSet("winter", testing::RandomMatrix(3, 4, 8));
  s.images = dir_->path() + "/images/winter";
  s.image_files = {"2.png", "0.png", "1.png"};
  SaveReferenceSet(*dir_, s, "sets/winter.yaml", /*replace=*/false);
  // Not below the YAML's folder: named absolute, which the data directory still accepts.
  EXPECT_NE(Slurp(Data("sets/winter.yaml")).find("images: " + dir_->path() + "/images/winter\n"),
            std::string::npos);
  ReferenceSet back = LoadReferenceSetFile(*dir_, "sets/winter.yaml", "");
  EXPECT_EQ(back.images, s.images);
  EXPECT_EQ(back.image_files, s.image_files);
  SaveReferenceSet(*dir_, back, "winter.yaml", /*replace=*/false);
  EXPECT_NE(Slurp(Data("winter.yaml")).find("images: images/winter\n"), std::string::npos);
  back = LoadReferenceSetFile(*dir_, "winter.yaml", "");
  EXPECT_EQ(back.images, s.images);
  EXPECT_EQ(back.image_files, s.image_files);
}

TEST(QuotedForMessage, CutsLongInputAndEscapesControlCharacters) {
  EXPECT_EQ(QuotedForMessage("abc"), "'abc'");
  EXPECT_EQ(QuotedForMessage("a\nb"), "'a\\x0ab'");
  const std::string q = QuotedForMessage(std::string(10000000, 'x'));
  EXPECT_LT(q.size(), 250u);
  EXPECT_NE(q.find("10000000 characters"), std::string::npos);
  EXPECT_TRUE(IsPrintableUtf8("nacht_\xc3\xa9t\xc3\xa9"));
  EXPECT_FALSE(IsPrintableUtf8("\xc0\xaf"));      // overlong '/'
  EXPECT_FALSE(IsPrintableUtf8("\xed\xa0\x80"));  // surrogate
  EXPECT_FALSE(IsPrintableUtf8("abc\xe2\x82"));   // cut short
}

// What a refusal echoes is what was sent, byte for byte readable: invalid UTF-8 as \xNN
// (it used to pass through raw), and the characters that reorder or hide the text around
// them as \uNNNN; readable UTF-8 as it is.
TEST(QuotedForMessage, EscapesInvalidUtf8BidiControlsAndInvisibleCharacters) {
  EXPECT_EQ(QuotedForMessage("a\xff\xfe" "b"), "'a\\xff\\xfeb'");
  EXPECT_EQ(QuotedForMessage("abc\xe2\x82"), "'abc\\xe2\\x82'");  // cut short
  EXPECT_EQ(QuotedForMessage("\xc0\xaf"), "'\\xc0\\xaf'");        // overlong '/'
  EXPECT_EQ(QuotedForMessage("abc\xe2\x80\xaegpj.exe"), "'abc\\u202egpj.exe'");
  EXPECT_EQ(QuotedForMessage("a\xe2\x80\x8b" "b\xc2\x85"), "'a\\u200bb\\u0085'");
  EXPECT_EQ(QuotedForMessage("nacht_\xc3\xa9t\xc3\xa9"), "'nacht_\xc3\xa9t\xc3\xa9'");
  EXPECT_EQ(UnreadableCharacter("ok \xc3\xa9"), "");
  EXPECT_EQ(UnreadableCharacter("ab\xe2\x80\xae"), "a bidirectional control (U+202E) at byte 2");
  EXPECT_EQ(UnreadableCharacter("a\xff"), "invalid UTF-8 at byte 1");
  for (const char* bidi : {"\xe2\x80\xaa", "\xe2\x80\xab", "\xe2\x80\xac", "\xe2\x80\xad",
                           "\xe2\x81\xa6", "\xe2\x81\xa7", "\xe2\x81\xa8", "\xe2\x81\xa9",
                           "\xe2\x80\x8e", "\xe2\x80\x8f", "\xd8\x9c"}) {
    EXPECT_FALSE(IsPrintableUtf8(std::string("x") + bidi)) << bidi;
  }
}

}  // namespace
}  // namespace bsf_vpr
