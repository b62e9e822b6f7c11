// Saving a set over an old one with a journal (save_journal.h, SaveReferenceSet,
// RecoverInterruptedSaves): killed at any moment, on a full disk, or beside files a person put
// there, the old set stays whole with its own images, nothing of the save is left behind, and
// no file that no save of ours wrote is ever removed.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <thread>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/io/internal/save_journal.h"
#include "src/io/internal/saved_descriptors.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

ReferenceSet Generation(int g, int rows);
std::vector<std::string> ImagesOf(int g, int rows, int bytes = 64);

class SaveJournalTest : public testing::TempDirTest {
 protected:
  // Every entry below the folder (files and folders, hidden ones too), relative, sorted.
  std::set<std::string> Entries() const {
    std::set<std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir_)) {
      out.insert(fs::relative(e.path(), dir_).string());
    }
    return out;
  }
  // Saves generation `g` of "today" (`rows` places) with its images, replacing what is there.
  static void SaveToday(const DataDirectory& dir, int g, int rows, SaveOptions options = {}) {
    const std::vector<std::string> images = ImagesOf(g, rows);
    options.replace = true;
    options.images = &images;
    SaveReferenceSet(dir, Generation(g, rows), "today.yaml", options);
  }
  void Age(const std::string& relative) const {
    fs::last_write_time(Path(relative), fs::file_time_type::clock::now() - std::chrono::hours(2));
  }
};

// Generation `g` of the set "today": its descriptors are all g, and row r's image says
// "gen g row r", so that a set's images can be told from another generation's.
ReferenceSet Generation(int g, int rows) {
  ReferenceSet set =
      MakeReferenceSet("today", RowMatrixXf::Constant(rows, 4, static_cast<float>(g)));
  return set;
}
std::vector<std::string> ImagesOf(int g, int rows, int bytes) {
  std::vector<std::string> images;
  for (int r = 0; r < rows; ++r) {
    std::string image = "gen " + std::to_string(g) + " row " + std::to_string(r) + " ";
    image.resize(static_cast<size_t>(bytes), 'x');
    images.push_back(image);
  }
  return images;
}

// The set at today.yaml is one generation, whole: its descriptors, and each row's image is
// its own generation's. Returns the generation.
int CheckWholeSet(const DataDirectory& dir, int rows) {
  const ReferenceSet set = LoadReferenceSetFile(dir, "today.yaml", "");
  EXPECT_EQ(set.size(), rows);
  const int g = static_cast<int>(set.descriptors(0, 0));
  EXPECT_TRUE((set.descriptors.array() == static_cast<float>(g)).all());
  ReferenceSets map;
  map.Add(set);
  for (int r = 0; r < rows; ++r) {
    const std::string image = ReadReferenceImage(map.set(0), r, &dir);
    EXPECT_EQ(image.rfind("gen " + std::to_string(g) + " row " + std::to_string(r) + " ", 0), 0u)
        << "row " << r << " of generation " << g << " shows: " << image.substr(0, 20);
  }
  return g;
}

// The entries a whole set at today.yaml consists of: the YAML, its .npy, its image folder and
// images.
std::set<std::string> FilesOfToday(const DataDirectory& dir) {
  std::set<std::string> out = {"today.yaml"};
  const ReferenceSet set = LoadReferenceSetFile(dir, "today.yaml", "");
  for (const std::string& f : FilesOfReferenceSets(dir, {dir.path() + "/today.yaml"})) {
    out.insert(f);
  }
  const std::string folder = set.images.substr(dir.path().size() + 1);
  for (const std::string& f : set.image_files) out.insert(folder + "/" + f);
  return out;
}

TEST_F(SaveJournalTest, StartUpRemovesNoFileThatNoSaveOfOursLeftWhateverItsNameOrAge) {
  const DataDirectory dir(dir_);
  // A set configured by its .npy, which no YAML names (it was saved, its YAML then deleted:
  // a save's own name and bytes), a .npy copied with its time (cp -p) before its YAML, and a
  // set whose YAML lies outside the directory: each old, none named below.
  SaveReferenceSet(dir, Generation(1, 3), "o4.yaml", false);
  std::string o4;
  for (const std::string& f : dir.ListFilesBelow()) {
    if (f.rfind("o4.", 0) == 0 && f != "o4.yaml") o4 = f;
  }
  fs::remove(Path("o4.yaml"));
  SaveReferenceSet(dir, Generation(2, 3), "copied/c.yaml", false);
  fs::remove(Path("copied/c.yaml"));
  fs::create_directories(dir_ + "_outside");
  SaveReferenceSet(dir, Generation(3, 3), "outside_named.yaml", false);
  fs::rename(Path("outside_named.yaml"), dir_ + "_outside/o.yaml");
  for (const std::string& f : dir.ListFilesBelow()) Age(f);
  const std::set<std::string> before = Entries();

  EXPECT_TRUE(RecoverInterruptedSaves(dir).empty());
  EXPECT_EQ(Entries(), before);
  EXPECT_EQ(LoadReferenceSetFile(dir, o4, "o4").size(), 3);
  fs::remove_all(dir_ + "_outside");
}

// Every regular file below the folder with its bytes, relative paths.
std::map<std::string, std::string> Contents(const std::string& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    out[fs::relative(e.path(), root).string()] =
        std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return out;
}

TEST_F(SaveJournalTest, HandMadeForeignAndMalformedJournalsRemoveNothingOfThePersons) {
  // Found attacking the node: journals written by hand, in the old format and in this one,
  // removed a person's files at start-up, and files that only had a journal's or a
  // temporary's name were removed without a word.
  const DataDirectory dir(dir_);
  SaveToday(dir, 1, 3);  // a real set, whose files a journal could name
  fs::create_directories(Path("sub"));
  std::ofstream(Path("mydata.csv")) << "1,2,3\n";
  std::ofstream(Path("sub/precious.txt")) << "precious";
  std::ofstream(Path("notes.txt")) << "notes";
  std::ofstream(Path("orphan_old.npy")) << "not a saved npy";
  std::ofstream(Path("finished.yaml")) << "name: x\n";
  // A YAML absent ("undo") and one present ("finish"), in the format of an earlier version.
  std::ofstream(Path(".ghost.yaml.bsf_save.XXXXXXXX"))
      << "bsf_vpr_save_journal: 1\nyaml: ghost.yaml\ndescriptors: ghost.a.npy\n"
         "created: [mydata.csv, sub/precious.txt]\ncreated_folders: [sub]\nreplaced: []\n"
         "replaced_folders: []\ncomplete: true\n";
  std::ofstream(Path(".finished.yaml.bsf_save.YYYYYYYY"))
      << "bsf_vpr_save_journal: 1\nyaml: finished.yaml\ndescriptors: f.npy\ncreated: []\n"
         "created_folders: []\nreplaced: [notes.txt, orphan_old.npy]\nreplaced_folders: []\n"
         "complete: true\n";
  // This version's format, with proofs that do not fit the files, or that fit another file.
  std::ofstream(Path(".ghost2.yaml.bsf_save.ZZZZZZZZ"))
      << "bsf_vpr_save_journal: 2\nyaml: ghost2.yaml\ndescriptors: ghost2.a.npy\n"
         "yaml_digest: 0000000000000000\n"
         "created: [mydata.csv, sub/precious.txt, orphan_old.npy]\n"
         "created_proofs: [content 0123456789abcdef, named by content, named by content]\n"
         "created_folders: [sub]\nreplaced: []\nreplaced_proofs: []\nreplaced_folders: []\n"
         "complete: true\n";
  std::ofstream(Path(".finished.yaml.bsf_save.WWWWWWWW"))
      << "bsf_vpr_save_journal: 2\nyaml: finished.yaml\ndescriptors: f.npy\n"
         "yaml_digest: " << ContentDigest("name: x\n") << "\n"
         "created: []\ncreated_proofs: []\ncreated_folders: []\n"
         "replaced: [notes.txt, sub/precious.txt]\n"
         "replaced_proofs: [content " << ContentDigest("other") << ", named by content]\n"
         "replaced_folders: [sub]\ncomplete: true\n";
  // No journal at all, one cut short, an empty one, and temporaries' look-alikes.
  std::ofstream(Path(".todo.yaml.bsf_save.CCCCCCCC")) << "- my\n- todo list\n";
  std::ofstream(Path(".cut.yaml.bsf_save.DDDDDDDD"))
      << "bsf_vpr_save_journal: 2\nyaml: cut.yaml\ncreated: [mydata.csv]\n";
  std::ofstream(Path(".empty.yaml.bsf_save.EEEEEEEE"));
  std::ofstream(Path(".mine.bsf_tmp.keep")) << "mine";
  std::ofstream(Path("sub/.precious.txt.bsf_tmp.abcdefgh")) << "a person's file after all";
  for (const std::string& f : dir.ListFilesBelow()) Age(f);
  const std::map<std::string, std::string> before = Contents(dir_);

  const std::vector<std::string> report = RecoverInterruptedSaves(dir);
  EXPECT_EQ(Contents(dir_), before) << "a file was removed or changed";
  // Each is reported as left, with its reason.
  std::string all;
  for (const std::string& line : report) all += line + "\n";
  for (const char* journal : {".ghost.yaml.bsf_save.XXXXXXXX", ".finished.yaml.bsf_save.YYYYYYYY",
                              ".ghost2.yaml.bsf_save.ZZZZZZZZ",
                              ".finished.yaml.bsf_save.WWWWWWWW", ".todo.yaml.bsf_save.CCCCCCCC",
                              ".cut.yaml.bsf_save.DDDDDDDD", ".empty.yaml.bsf_save.EEEEEEEE"}) {
    EXPECT_NE(all.find(std::string("left '") + journal + "'"), std::string::npos)
        << journal << " not reported in:\n"
        << all;
  }
  EXPECT_NE(all.find("version 1"), std::string::npos) << all;
  EXPECT_NE(all.find("not those the save wrote"), std::string::npos) << all;
  EXPECT_EQ(CheckWholeSet(dir, 3), 1);
}

TEST_F(SaveJournalTest, AReplacedSetsOwnFilesGoAndAConfiguredOrNamedOneStays) {
  const DataDirectory dir(dir_);
  SaveToday(dir, 1, 4);
  EXPECT_EQ(CheckWholeSet(dir, 4), 1);
  const std::set<std::string> first = FilesOfToday(dir);
  // Overwritten: the new set with its images; the old set's files are gone.
  SaveToday(dir, 2, 4);
  EXPECT_EQ(CheckWholeSet(dir, 4), 2);
  EXPECT_EQ(Entries(), FilesOfToday(dir));
  // A configured set (keep) or another YAML naming the old files keeps them.
  const std::set<std::string> second = FilesOfToday(dir);
  SaveOptions options;
  options.keep = FilesOfReferenceSets(dir, {dir.path() + "/today.yaml"});
  SaveToday(dir, 3, 4, options);
  EXPECT_EQ(CheckWholeSet(dir, 4), 3);
  for (const std::string& f : second) {
    if (f == "today.yaml") continue;
    EXPECT_TRUE(fs::exists(Path(f))) << f;
  }
  // The first generation's files went with the second save.
  for (const std::string& f : first) {
    if (f == "today.yaml") continue;
    EXPECT_FALSE(fs::exists(Path(f))) << f;
  }
}

TEST_F(SaveJournalTest, PlacesWithoutAnImageAreSavedWithoutOneAndTheOthersWithTheirs) {
  const DataDirectory dir(dir_);
  std::vector<std::string> images = ImagesOf(5, 6);
  images[0].clear();  // came before the image subscription connected
  images[4].clear();
  SaveOptions options;
  options.images = &images;
  const SavedImages saved = SaveReferenceSet(dir, Generation(5, 6), "today.yaml", options);
  ASSERT_EQ(saved.image_files.size(), 6u);
  EXPECT_EQ(saved.image_files[0], "");
  EXPECT_EQ(saved.image_files[1], "000001.jpg");
  const ReferenceSet set = LoadReferenceSetFile(dir, "today.yaml", "");
  EXPECT_EQ(set.image_files, saved.image_files);
  ReferenceSets map;
  map.Add(set);
  EXPECT_EQ(ReadReferenceImage(map.set(0), 1, &dir), images[1]);
  EXPECT_THROW(ReadReferenceImage(map.set(0), 4, &dir), std::invalid_argument);
}

TEST_F(SaveJournalTest, AFailedSaveLeavesTheOldSetAndNothingOfItsOwn) {
  const DataDirectory dir(dir_);
  SaveToday(dir, 1, 5);
  const std::set<std::string> before = Entries();
  // The new descriptors cannot be written (a folder stands where their file goes), after
  // the images were: the save fails on the way.
  const std::string npy =
      SavedDescriptorPath("today", EncodeNpyMatrix(Generation(2, 5).descriptors));
  fs::create_directories(Path(npy + "/blocker"));
  EXPECT_THROW(SaveToday(dir, 2, 5), std::runtime_error);
  fs::remove_all(Path(npy));
  EXPECT_EQ(Entries(), before);
  EXPECT_EQ(CheckWholeSet(dir, 5), 1);
}

// A save in a child process, killed `delay` after it started unless `delay` is zero (then
// it runs to its end); returns the child's wait status. Its descriptors are generation
// `descriptors_g` (default `g`), its images generation `g`.
int KilledSave(const std::string& root, int g, int rows, std::chrono::microseconds delay,
               int descriptors_g = 0) {
  const pid_t child = fork();
  if (child == 0) {
    const DataDirectory dir(root);
    SaveOptions options;
    options.replace = true;
    const std::vector<std::string> images = ImagesOf(g, rows, 4096);
    options.images = &images;
    SaveReferenceSet(dir, Generation(descriptors_g ? descriptors_g : g, rows), "today.yaml",
                     options);
    _exit(0);
  }
  if (delay.count() > 0) {
    std::this_thread::sleep_for(delay);
    kill(child, SIGKILL);  // (harmless if it has just ended)
  }
  int status = 0;
  waitpid(child, &status, 0);
  return status;
}

TEST_F(SaveJournalTest, KilledAtAnyMomentTheOldSetStaysWholeWithItsOwnImagesAndNothingIsLeft) {
  const DataDirectory dir(dir_);
  constexpr int kRows = 120;
  {
    SaveOptions options;
    const std::vector<std::string> images = ImagesOf(1, kRows, 4096);
    options.images = &images;
    SaveReferenceSet(dir, Generation(1, kRows), "today.yaml", options);
  }
  // How long one save takes here (in a child, as below).
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(KilledSave(dir_, 2, kRows, std::chrono::microseconds(0)), 0);
  const auto save_time = std::chrono::duration_cast<std::chrono::microseconds>(
      std::chrono::steady_clock::now() - start);
  ASSERT_EQ(CheckWholeSet(dir, kRows), 2);
  int caught = 0, generation = 2;
  constexpr int kKills = 24;
  for (int k = 0; k < kKills; ++k) {
    // Spread over the save, from its start to just past its end.
    const auto delay = save_time * (k + 1) / (kKills - 2);
    KilledSave(dir_, generation + 1, kRows, delay);
    const std::vector<std::string> report = RecoverInterruptedSaves(dir);
    caught += !report.empty();
    // Whole, one generation: the old one (killed before the YAML's rename) or the new one.
    const int now = CheckWholeSet(dir, kRows);
    EXPECT_TRUE(now == generation || now == generation + 1) << now << " after " << generation;
    generation = now;
    // Nothing else is left: no journal, no temporary, no images of the other generation.
    EXPECT_EQ(Entries(), FilesOfToday(dir)) << "kill " << k << " left files behind";
  }
  // The kills must have landed inside saves, or this test said nothing.
  EXPECT_GE(caught, 3) << "of " << kKills << " kills, " << caught << " interrupted a save";
}

TEST_F(SaveJournalTest, TheSameDescriptorsRecordedAgainAndKilledLeaveOneSetOfImages) {
  // The same route's frames recorded again: the new .npy has the old one's name (named by
  // content), so only the YAML's own bytes tell whether the save got to its end. Found
  // driving the node live: a kill left the new, partial image folder behind.
  const DataDirectory dir(dir_);
  constexpr int kRows = 120;
  ASSERT_EQ(KilledSave(dir_, 1, kRows, std::chrono::microseconds(0)), 0);
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(KilledSave(dir_, 2, kRows, std::chrono::microseconds(0), 1), 0);
  const auto save_time = std::chrono::duration_cast<std::chrono::microseconds>(
      std::chrono::steady_clock::now() - start);
  int caught = 0;
  for (int k = 0; k < 12; ++k) {
    KilledSave(dir_, 3 + k, kRows, save_time * (k + 1) / 10, 1);
    caught += !RecoverInterruptedSaves(dir).empty();
    const ReferenceSet set = LoadReferenceSetFile(dir, "today.yaml", "");
    EXPECT_TRUE((set.descriptors.array() == 1.0f).all());
    // One generation of images, whole, and nothing else left.
    ReferenceSets map;
    map.Add(set);
    const std::string first = ReadReferenceImage(map.set(0), 0, &dir);
    const std::string g = first.substr(0, first.find(" row "));
    for (int r = 0; r < kRows; ++r) {
      EXPECT_EQ(
          ReadReferenceImage(map.set(0), r, &dir).rfind(g + " row " + std::to_string(r) + " ", 0),
          0u);
    }
    EXPECT_EQ(Entries(), FilesOfToday(dir)) << "kill " << k << " left files behind";
  }
  EXPECT_GE(caught, 3);
}

TEST_F(SaveJournalTest, ASaveRunningInAnotherProcessIsLeftAlone) {
  const DataDirectory dir(dir_);
  SaveFiles files;
  files.yaml = "today.yaml";
  files.yaml_digest = ContentDigest("name: today\n");
  files.descriptors = SavedDescriptorPath("today", "being written");
  files.created = {files.descriptors};
  files.created_proofs = {ProofByName()};
  WriteRaw(files.descriptors, "being written");
  {
    SaveJournal running(dir, files);  // holds the journal's lock, as a live save does
    const pid_t child = fork();
    if (child == 0) _exit(RecoverInterruptedSaves(dir).empty() ? 0 : 1);
    int status = 0;
    waitpid(child, &status, 0);
    EXPECT_EQ(WEXITSTATUS(status), 0);
    EXPECT_TRUE(fs::exists(Path(files.descriptors)));
  }
  // Its process gone without finishing (the lock released): undone.
  EXPECT_EQ(RecoverInterruptedSaves(dir).size(), 1u);
  EXPECT_FALSE(fs::exists(Path(files.descriptors)));
  EXPECT_TRUE(Entries().empty());
}

// A small file system of its own (tmpfs), for a full disk; root only.
class FullDisk : public SaveJournalTest {
 protected:
  void SetUp() override {
    SaveJournalTest::SetUp();
    if (geteuid() != 0) GTEST_SKIP() << "mounting a small file system needs root";
    mount_ = Path("disk");
    fs::create_directories(mount_);
    ASSERT_EQ(mount("tmpfs", mount_.c_str(), "tmpfs", 0, "size=600k"), 0)
        << "cannot mount a tmpfs: " << std::strerror(errno);
  }
  void TearDown() override {
    if (!mount_.empty()) umount(mount_.c_str());
    SaveJournalTest::TearDown();
  }
  std::string mount_;
};

TEST_F(FullDisk, ASaveThatFillsTheDiskLeavesTheOldSetAndItsSpaceAndTheNextSmallerSaveWorks) {
  const DataDirectory dir(mount_);
  SaveOptions options;
  options.replace = true;
  const std::vector<std::string> g1 = ImagesOf(1, 40, 4096);
  options.images = &g1;
  SaveReferenceSet(dir, Generation(1, 40), "today.yaml", options);
  std::set<std::string> before;
  for (const auto& e : fs::recursive_directory_iterator(mount_)) before.insert(e.path().string());
  // Twice the disk's room in images: the disk fills on the way.
  const std::vector<std::string> big = ImagesOf(2, 300, 4096);
  options.images = &big;
  EXPECT_THROW(SaveReferenceSet(dir, Generation(2, 300), "today.yaml", options),
               std::runtime_error);
  std::set<std::string> after;
  for (const auto& e : fs::recursive_directory_iterator(mount_)) after.insert(e.path().string());
  EXPECT_EQ(after, before) << "the failed save left files behind";
  const ReferenceSet set = LoadReferenceSetFile(dir, "today.yaml", "");
  EXPECT_EQ(set.size(), 40);
  // The room is back: a smaller recording saves.
  const std::vector<std::string> g3 = ImagesOf(3, 60, 4096);
  options.images = &g3;
  SaveReferenceSet(dir, Generation(3, 60), "today.yaml", options);
  EXPECT_EQ(LoadReferenceSetFile(dir, "today.yaml", "").size(), 60);
}

}  // namespace
}  // namespace bsf_vpr
