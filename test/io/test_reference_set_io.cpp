// Reference sets in files (reference_set_io.h): the YAML sidecar and its .npy.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "test/core/test_util.h"

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

TEST_F(ReferenceSetIo, EveryWayOfNamingASetMeetsTheSameNameRule) {
  WriteNpyMatrix(Path("d.npy"), testing::RandomMatrix(3, 4, 5));
  WriteRaw("good.yaml", "name: good\ndescriptors: d.npy\n");
  const std::string long_name(5000, 'n');
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"a\nb", "'a\\x0ab' holds a control character (U+000A) at byte 1"},
      {"bell\a", "'bell\\x07'"},
      {"\xff\xfe", "'\\xff\\xfe' holds invalid UTF-8 at byte 0"},  // the bytes escaped
      // A right-to-left override shows "abc<U+202E>gpj.exe" as "abcexe.jpg".
      {"abc\xe2\x80\xaegpj.exe",
       "'abc\\u202egpj.exe' holds a bidirectional control (U+202E) at byte 3"},
      {"\xe2\x81\xa6x", "a bidirectional control (U+2066)"},
      {"a\xe2\x80\x8b" "b", "an invisible character (U+200B)"},
      {"a\xef\xbb\xbf", "an invisible character (U+FEFF)"},
      {"a\xe2\x80\xa8" "b", "a line or paragraph separator (U+2028)"},
      {" ", "set name ' ' is only spaces"},
      {"\xe3\x80\x80 ", "is only spaces"},
      {" lead", "set name ' lead' starts or ends with a space"},
      {"trail\xc2\xa0", "starts or ends with a space"},
      {long_name, "(5000 characters) is too long"},
      {std::string(129, 'x'), "(129 characters) is too long"},
  };
  const DataDirectory dir(dir_);
  const auto refusal = [](const auto& load) {
    try {
      load();
      return std::string("accepted");
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  };
  for (const auto& entry : bad) {
    // Copies, not structured bindings: a C++17 lambda cannot capture a binding (clang).
    const std::string name = entry.first, expect = entry.second;
    // The YAML's own name, a caller's name for a YAML or an .npy (the command line, the
    // configured sets), a service's request below the data directory, and a save.
    std::string quoted = "\"";  // control characters as YAML escapes, other bytes as they are
    for (const char c : name) {
      char escape[8];
      std::snprintf(escape, sizeof(escape), "\\x%02x", static_cast<unsigned char>(c));
      quoted += static_cast<unsigned char>(c) < 0x20 ? std::string(escape) : std::string(1, c);
    }
    WriteRaw("named.yaml", "name: " + quoted + "\"\ndescriptors: d.npy\n");
    const std::vector<std::string> refusals = {
        refusal([&] { LoadReferenceSetFile(Path("named.yaml"), ""); }),
        refusal([&] { LoadReferenceSetFile(Path("good.yaml"), name); }),
        refusal([&] { LoadReferenceSetNpy(Path("d.npy"), name); }),
        refusal([&] { LoadReferenceSetFile(dir, "good.yaml", name); }),
        refusal([&] { LoadReferenceSetFile(dir, "named.yaml", ""); }),
        refusal([&] {
          SaveReferenceSet(MakeReferenceSet(name, testing::RandomMatrix(2, 4, 1)),
                           Path("saved.yaml"));
        })};
    // A name the caller gave is blamed, not the file it was given for.
    for (size_t k : {1, 2, 3}) {
      EXPECT_EQ(refusals[k].rfind("the name given for '", 0), 0u) << refusals[k];
      EXPECT_NE(refusals[k].find("' is refused: set name "), std::string::npos) << refusals[k];
    }
    for (const std::string& why : refusals) {
      EXPECT_NE(why.find(expect), std::string::npos) << why;
      EXPECT_NE(why.find("1 to 128 bytes of printable UTF-8"), std::string::npos) << why;
      EXPECT_LT(why.size(), 600u) << "the name is shown cut short";
    }
  }
  EXPECT_FALSE(fs::exists(Path("saved.yaml")));
  // Printable UTF-8 of up to 128 bytes, spaces and folders included, is a name.
  for (const std::string& name : std::vector<std::string>{
           "nacht_\xc3\xa9t\xc3\xa9", "route a/tonight", std::string(128, 'x')}) {
    EXPECT_EQ(SetNameProblem(name), "") << name;
    EXPECT_EQ(LoadReferenceSetFile(Path("good.yaml"), name).name, name);
  }
}

// A folder of image files (any content: only names and bytes matter here).
void MakeImages(const std::string& folder, const std::vector<std::string>& names) {
  fs::create_directories(folder);
  for (const std::string& name : names) {
    fs::create_directories(fs::path(folder + "/" + name).parent_path());
    std::ofstream(folder + "/" + name) << "image " << name;
  }
}

std::string Refusal(const std::string& yaml) {
  try {
    LoadReferenceSetFile(yaml, "");
    return "accepted";
  } catch (const std::runtime_error& e) {
    return e.what();
  }
}

TEST_F(ReferenceSetIo, PosesThatAreNotFiniteOrAbsurdAreRefusedNamingFileRowPlaceAndValue) {
  WriteNpyMatrix(Path("d.npy"), testing::RandomMatrix(3, 4, 5));
  const std::string head = "name: route\ndescriptors: d.npy\nplace_ids: [7, 8, 9]\nposes: ";
  for (const auto& [poses, value] : std::vector<std::pair<std::string, std::string>>{
           {"[[0, 0, 0, 0], [.nan, 0, 0, 0], [2, 0, 0, 0]]", "x = nan"},
           {"[[0, 0, 0, 0], [1, 0, 0, .inf], [2, 0, 0, 0]]", "yaw = inf"},
           {"[[0, 0, 0, 0], [1e12, 0, 0, 0], [2, 0, 0, 0]]", "x = 1e+12"}}) {
    WriteRaw("route.yaml", head + poses + "\n");
    const std::string why = Refusal(Path("route.yaml"));
    for (const std::string& part :
         std::vector<std::string>{"route.yaml", "row 1", "place 8", value}) {
      EXPECT_NE(why.find(part), std::string::npos) << part << " in: " << why;
    }
  }
  WriteRaw("route.yaml", head + "[[0, 0, 0, 0], [1, 0, 0, 0], [2, 0, 0, 0]]\n");
  EXPECT_EQ(LoadReferenceSetFile(Path("route.yaml"), "").poses.size(), 3u);
}

TEST_F(ReferenceSetIo, ImagesNameTheFolderAndRowKIsItsKthImageByName) {
  WriteNpyMatrix(Path("d.npy"), testing::RandomMatrix(3, 4, 5));
  // Other files and folders, whatever their names, are not images of the set.
  MakeImages(Path("imgs"), {"b.png", "a.jpg", "c.PNG", "notes.txt", "sub/x.png"});
  fs::create_directory(Path("imgs/folder.png"));
  for (const std::string& field :
       {std::string("imgs"), std::string("imgs/"), std::string("./imgs/sub/.."), Path("imgs")}) {
    WriteRaw("s.yaml", "name: s\ndescriptors: d.npy\nimages: " + field + "\n");
    const ReferenceSet s = LoadReferenceSetFile(Path("s.yaml"), "");
    EXPECT_EQ(s.images, Path("imgs")) << field;  // absolute, normalised
    EXPECT_EQ(s.image_files, (std::vector<std::string>{"a.jpg", "b.png", "c.PNG"})) << field;
  }
  // A set without images has none.
  WriteRaw("plain.yaml", "name: p\ndescriptors: d.npy\n");
  const ReferenceSet plain = LoadReferenceSetFile(Path("plain.yaml"), "");
  EXPECT_TRUE(plain.images.empty());
  EXPECT_TRUE(plain.image_files.empty());
  // image_files: any files below the folder, in the rows' order.
  WriteRaw("l.yaml",
           "name: l\ndescriptors: d.npy\nimages: imgs\n"
           "image_files: [sub/x.png, notes.txt, a.jpg]\n");
  const ReferenceSet listed = LoadReferenceSetFile(Path("l.yaml"), "");
  EXPECT_EQ(listed.images, Path("imgs"));
  EXPECT_EQ(listed.image_files, (std::vector<std::string>{"sub/x.png", "notes.txt", "a.jpg"}));
}

TEST_F(ReferenceSetIo, WrongImagesRefuseTheWholeSetNamingTheProblem) {
  WriteNpyMatrix(Path("d.npy"), testing::RandomMatrix(3, 4, 5));
  MakeImages(Path("imgs"), {"a.png", "b.png", "c.png", "d.png", "sub/x.png"});
  MakeImages(Path("three"), {"a.png", "b.png", "c.png"});
  MakeImages(Path("other"), {"a.png"});
  WriteRaw("file.png", "");
  const std::string head = "name: s\ndescriptors: d.npy\n";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"images: imgs\n",
       "images: 'imgs' holds 4 image files for 3 descriptors; list each row's file with "
       "image_files"},
      {"images: nowhere\n", "images: '" + Path("nowhere") + "' is not a folder"},
      {"images: file.png\n", "images: '" + Path("file.png") + "' is not a folder"},
      {"images: ''\n", "'images' is empty"},
      {"images: nowhere\nimage_files: [a.png, b.png, c.png]\n", "is not a folder"},
      {"image_files: [a.png, b.png, c.png]\n", "'image_files' needs 'images'"},
      {"images: imgs\nimage_files: [a.png, b.png]\n",
       "images: 'image_files' lists 2 files for 3 descriptors"},
      {"images: imgs\nimage_files: a.png\n", "'image_files' is not a list"},
      {"images: imgs\nimage_files: [a.png, /etc/passwd, c.png]\n",
       "image_files[1] '/etc/passwd' is absolute"},
      {"images: imgs\nimage_files: [a.png, b.png, ../other/a.png]\n",
       "image_files[2] '../other/a.png' has a '..' part"},
      {"images: imgs\nimage_files: [a.png, sub/../../other/a.png, c.png]\n", "'..' part"},
      {"images: imgs\nimage_files: [a.png, gone.png, c.png]\n",
       "image_files[1] 'gone.png' is not a file in images 'imgs'"},
      {"images: imgs\nimage_files: [a.png, b.png, nosub/x.png]\n",
       "image_files[2] 'nosub/x.png' is not a file in images 'imgs'"},
      {"images: imgs\nimage_files: [a.png, b.png, sub]\n", "image_files[2] 'sub' is not a file"},
  };
  for (const auto& [text, fragment] : bad) {
    WriteRaw("s.yaml", head + text);
    const std::string why = Refusal(Path("s.yaml"));
    EXPECT_NE(why.find("reference set file '" + Path("s.yaml") + "'"), std::string::npos) << why;
    EXPECT_NE(why.find(fragment), std::string::npos) << text << "\n" << why;
  }
  // The same folder with the right count, or a list, is accepted.
  WriteRaw("s.yaml", head + "images: three\n");
  EXPECT_EQ(LoadReferenceSetFile(Path("s.yaml"), "").image_files.size(), 3u);
  WriteRaw("s.yaml", head + "images: imgs\nimage_files: [d.png, sub/x.png, a.png]\n");
  EXPECT_EQ(LoadReferenceSetFile(Path("s.yaml"), "").image_files[1], "sub/x.png");
  // A row without an image: an empty entry, loaded as such; reading it says so.
  WriteRaw("s.yaml", head + "images: imgs\nimage_files: [d.png, '', a.png]\n");
  const ReferenceSet partial = LoadReferenceSetFile(Path("s.yaml"), "");
  EXPECT_EQ(partial.image_files[1], "");
  ReferenceSets map;
  map.Add(partial);
  EXPECT_EQ(ReadReferenceImage(map.set(0), 0, nullptr), "image d.png");
  try {
    ReadReferenceImage(map.set(0), 1, nullptr);
    ADD_FAILURE() << "a row without an image was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("row 1 has no image"), std::string::npos) << e.what();
  }
}

// The `images:` line a saved YAML holds.
std::string ImagesLine(const std::string& yaml) {
  std::ifstream in(yaml);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("images:", 0) == 0) return line;
  }
  return "";
}

TEST_F(ReferenceSetIo, SavedImagesRoundTripRelativeBelowTheYamlElseAbsolute) {
  MakeImages(Path("sets/imgs"), {"a.png", "b.png", "c d.png", "sub/e.png"});
  MakeImages(Path("elsewhere"), {"a.png", "b.png", "c d.png", "sub/e.png"});
  ReferenceSet s = MakeReferenceSet("s", testing::RandomMatrix(3, 4, 5));
  const std::vector<std::string> files = {"c d.png", "sub/e.png", "a.png"};  // not in order
  const struct {
    std::string images, loaded, line;
    std::vector<std::string> files;
  } cases[] = {
      {Path("sets/imgs"), Path("sets/imgs"), "images: imgs", files},
      {Path("sets/./x/../imgs/"), Path("sets/imgs"), "images: imgs", files},
      {Path("elsewhere"), Path("elsewhere"), "images: " + Path("elsewhere"), files},
      // The YAML's own folder.
      {Path("sets"), Path("sets"), "images: .", {"imgs/c d.png", "imgs/sub/e.png", "imgs/a.png"}},
  };
  for (const auto& c : cases) {
    s.images = c.images;
    s.image_files = c.files;
    SaveReferenceSet(s, Path("sets/s.yaml"));
    EXPECT_EQ(ImagesLine(Path("sets/s.yaml")), c.line) << c.images;
    const ReferenceSet back = LoadReferenceSetFile(Path("sets/s.yaml"), "");
    EXPECT_EQ(back.images, c.loaded) << c.images;
    EXPECT_EQ(back.image_files, c.files) << c.images;
    EXPECT_EQ(back.place_ids, s.place_ids);
  }
  // image_files are written explicitly, as a flow list.
  s.images = Path("sets/imgs");
  s.image_files = {"a.png", "b.png", "c d.png"};  // the folder's order: still listed
  SaveReferenceSet(s, Path("sets/s.yaml"));
  const std::string text = ReadFile(Path("sets/s.yaml"));
  EXPECT_NE(text.find("image_files: [a.png, b.png, c d.png]"), std::string::npos) << text;
  // A set without images writes neither key.
  SaveReferenceSet(MakeReferenceSet("p", testing::RandomMatrix(3, 4, 5)), Path("sets/p.yaml"));
  EXPECT_EQ(ReadFile(Path("sets/p.yaml")).find("image"), std::string::npos);
  // An invalid set is not saved.
  s.image_files.pop_back();
  EXPECT_THROW(SaveReferenceSet(s, Path("sets/bad.yaml")), std::invalid_argument);
  EXPECT_FALSE(fs::exists(Path("sets/bad.yaml")));
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

class MappedSets : public testing::TempDirTest {};

// A set written as a map holds it (SaveStoredReferenceSet) is mapped, not read, by a loader
// asking for its precision; its rows, scale and distances are those of the set encoded from
// float32, and it outlives its file being replaced (a rename) or removed.
TEST_F(MappedSets, AStoredSetIsMappedAtItsPrecisionAndReadOtherwise) {
  ReferenceSet s = MakeReferenceSet("winter", testing::RandomMatrix(7, 19, 5));
  s.condition = "snow";
  s.poses.assign(7, PlacePose{1, 2, 0, 0});
  for (const StoragePrecision p :
       {StoragePrecision::kFloat32, StoragePrecision::kFloat16, StoragePrecision::kInt8}) {
    const std::string what = ToString(p);
    ReferenceSets resident;
    resident.SetStoragePrecision(p);
    resident.Add(s);
    const std::string yaml = Path("stored_" + what + ".yaml");
    SaveStoredReferenceSet(resident.set(0), yaml);
    // The rows' file, named by the set's stem, its precision and its content.
    const auto rows_files = [&] {
      std::vector<std::string> out;
      for (const auto& e : fs::directory_iterator(dir_)) {
        const std::string f = e.path().filename().string();
        if (f.rfind("stored_" + what + "." + what + ".", 0) == 0) out.push_back(f);
      }
      return out;
    };
    ASSERT_EQ(rows_files().size(), 1u) << what;
    const std::string first_rows = rows_files()[0];
    EXPECT_EQ(first_rows.size(), ("stored_" + what + "." + what + ".0123456789ab.npy").size());

    ReadSetOptions options;
    options.memory_map = p;
    ReferenceSet loaded = LoadReferenceSetFile(yaml, "", options);
    ASSERT_TRUE(loaded.encoded.has_value()) << what;
    EXPECT_EQ(loaded.descriptors.size(), 0);
    EXPECT_EQ(loaded.size(), 7);
    EXPECT_EQ(loaded.dimension(), 19);
    EXPECT_EQ(loaded.condition, "snow");
    EXPECT_EQ(loaded.poses.size(), 7u);
    EXPECT_NE(loaded.encoded->source.find("memory-mapped"), std::string::npos);
    ReferenceSets mapped;
    mapped.SetStoragePrecision(p);
    mapped.Add(std::move(loaded));
    ASSERT_TRUE(mapped.set(0).mapped());
    EXPECT_EQ(mapped.set(0).scale(), resident.set(0).scale()) << what;
    ASSERT_EQ(
        std::memcmp(mapped.set(0).data(), resident.set(0).data(), resident.set(0).data_bytes()), 0)
        << what;

    // Replaced by another set: its rows go to a file of their own, the YAML names it, and
    // the old rows' file is removed; the mapped set keeps the rows it was loaded with.
    const RowMatrixXf q = testing::RandomMatrix(3, 19, 9);
    const auto before = ComputeDistances(DistanceMetric::kCosine, q, mapped);
    ReferenceSets other;
    other.SetStoragePrecision(p);
    other.Add(MakeReferenceSet("winter", testing::RandomMatrix(7, 19, 77)));
    SaveStoredReferenceSet(other.set(0), yaml);
    ASSERT_EQ(rows_files().size(), 1u) << what;
    EXPECT_NE(rows_files()[0], first_rows);
    const auto after = ComputeDistances(DistanceMetric::kCosine, q, mapped);
    EXPECT_EQ(std::memcmp(before[0].data(), after[0].data(), sizeof(float) * before[0].size()), 0);
    ReferenceSets reloaded;
    reloaded.SetStoragePrecision(p);
    reloaded.Add(LoadReferenceSetFile(yaml, "", options));
    EXPECT_EQ(std::memcmp(reloaded.set(0).data(), other.set(0).data(), other.set(0).data_bytes()),
              0);
  }

  // At another precision than the file's, the rows are read (int8 decoded by its scale).
  ReferenceSets int8;
  int8.SetStoragePrecision(StoragePrecision::kInt8);
  int8.Add(s);
  SaveStoredReferenceSet(int8.set(0), Path("w8.yaml"));
  ReadSetOptions f32;
  f32.memory_map = StoragePrecision::kFloat32;
  const ReferenceSet read = LoadReferenceSetFile(Path("w8.yaml"), "", f32);
  EXPECT_FALSE(read.encoded.has_value());
  RowMatrixXf decoded(7, 19);
  for (int r = 0; r < 7; ++r) int8.set(0).DecodeRow(r, decoded.row(r).data());
  EXPECT_TRUE(read.descriptors.isApprox(decoded, 0));
  EXPECT_TRUE(LoadReferenceSetFile(Path("w8.yaml"), "").descriptors.isApprox(decoded, 0));

  // A set read from a float32 file into an int8 map, and the same set mapped from its int8
  // file, answer with the same bits.
  ReadSetOptions i8;
  i8.memory_map = StoragePrecision::kInt8;
  ReferenceSets a, b;
  a.SetStoragePrecision(StoragePrecision::kInt8);
  b.SetStoragePrecision(StoragePrecision::kInt8);
  a.Add(s);
  b.Add(LoadReferenceSetFile(Path("w8.yaml"), "", i8));
  const RowMatrixXf q = testing::RandomMatrix(2, 19, 3);
  const auto da = ComputeDistances(DistanceMetric::kEuclidean, q, a);
  const auto db = ComputeDistances(DistanceMetric::kEuclidean, q, b);
  EXPECT_EQ(std::memcmp(da[0].data(), db[0].data(), sizeof(float) * da[0].size()), 0);
}

TEST_F(MappedSets, RefusesAnInt8FileWithoutItsScaleAndMapsOnlyBelowTheDataDirectory) {
  const int8_t levels[6] = {1, -2, 3, 4, 5, -127};
  WriteFileAtomically(Path("raw.npy"), EncodeNpyBytes(levels, 2, 3, NpyDtype::kInt8));
  ReadSetOptions i8;
  i8.memory_map = StoragePrecision::kInt8;
  for (const ReadSetOptions& options : {ReadSetOptions(), i8}) {
    try {
      LoadReferenceSetFile(Path("raw.npy"), "raw", options);
      ADD_FAILURE() << "an int8 .npy without a scale was taken";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("int8"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("descriptor_scale"), std::string::npos) << e.what();
    }
  }
  std::ofstream(Path("bad_scale.yaml")) << "name: b\ndescriptors: raw.npy\ndescriptor_scale: -1\n";
  try {
    LoadReferenceSetFile(Path("bad_scale.yaml"), "", i8);
    ADD_FAILURE() << "a negative scale was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'descriptor_scale' must be a positive number"),
              std::string::npos)
        << e.what();
  }
  // A scale at which the rows vanish (1e-25: every int8 row decodes to zero in float's
  // squared norms; 1e-45: a denormal) is refused, read or mapped.
  for (const char* tiny : {"1e-25", "1e-45", "1e-19"}) {
    std::ofstream(Path("tiny_scale.yaml"))
        << "name: t\ndescriptors: raw.npy\ndescriptor_scale: " << tiny << "\n";
    for (const ReadSetOptions& options : {ReadSetOptions(), i8}) {
      try {
        LoadReferenceSetFile(Path("tiny_scale.yaml"), "", options);
        ADD_FAILURE() << "descriptor_scale " << tiny << " was taken";
      } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("is too small"), std::string::npos) << e.what();
      }
    }
  }
  std::ofstream(Path("small_ok.yaml")) << "name: s\ndescriptors: raw.npy\ndescriptor_scale: 2e-19\n";
  EXPECT_NO_THROW(LoadReferenceSetFile(Path("small_ok.yaml"), "", i8));
  std::ofstream(Path("ok.yaml")) << "name: ok\ndescriptors: raw.npy\ndescriptor_scale: 0.5\n";
  const DataDirectory dir(dir_);
  const ReferenceSet below = LoadReferenceSetFile(dir, "ok.yaml", "", i8);
  ASSERT_TRUE(below.encoded.has_value());
  EXPECT_EQ(below.encoded->scale, 0.5f);
  // A link below the data directory is not followed, mapped or not.
  fs::create_symlink(Path("raw.npy"), Path("link.npy"));
  std::ofstream(Path("linked.yaml")) << "name: l\ndescriptors: link.npy\ndescriptor_scale: 1\n";
  EXPECT_THROW(LoadReferenceSetFile(dir, "linked.yaml", "", i8), std::runtime_error);
  EXPECT_THROW(LoadReferenceSetFile(dir, "../outside.yaml", "", i8), std::exception);
}

}  // namespace
}  // namespace bsf_vpr
