// End-to-end tests of the tools that make bsf_vpr's inputs (bsf_make_reference,
// bsf_make_bag, bsf_make_synthetic, bsf_make_views), run as a user would run them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bsf_vpr/image/image_describer.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "test/core/test_util.h"
#include "test/tools/tool_test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;
const std::string kSource = BSF_SOURCE_DIR;
const std::string kGardens = kSource + "/data/gardens_point_hdc_delf/";

using testing::Evaluate;
using testing::ExpectOneLineRefusal;
using testing::Lines;
using testing::Result;
using testing::RunCommand;

// A fresh temporary folder dir_ per test (test_util.h).
class MakeTools : public testing::TempDirTest {};

TEST_F(MakeTools, MakeReferenceAndMakeBagWriteFilesOrFailCleanly) {
  const std::string mk_ref = BSF_MAKE_REFERENCE_PATH, mk_bag = BSF_MAKE_BAG_PATH;
  EXPECT_EQ(RunCommand(mk_ref + " --help").exit_code, 0);
  EXPECT_EQ(RunCommand(mk_bag + " --help").exit_code, 0);
  const Result ref =
      RunCommand(mk_ref + " --descriptors " + kGardens + "day_left.npy --name day " +
                 "--condition day --distance cosine --out " + dir_ + "/sets/day.yaml");
  ASSERT_EQ(ref.exit_code, 0) << ref.output;
  const ReferenceSet day = LoadReferenceSetFile(dir_ + "/sets/day.yaml", "");
  EXPECT_EQ(day.size(), 200);
  EXPECT_EQ(day.condition, "day");
  EXPECT_EQ(day.distance, "cosine");
  const Result bag = RunCommand(mk_bag + " --descriptors " + kGardens + "night_right.npy " +
                                "--tolerance 8 --rate 20 --limit 50 --out " + dir_ + "/night.bag");
  ASSERT_EQ(bag.exit_code, 0) << bag.output;
  EXPECT_NE(bag.output.find("50 queries"), std::string::npos) << bag.output;
  EXPECT_TRUE(fs::exists(dir_ + "/night.bag"));
  // A bag of queries holds no beliefs: the results-bag mode says so.
  const Result no_beliefs = Evaluate("--results-bag " + dir_ + "/night.bag --tolerance 2");
  EXPECT_EQ(no_beliefs.exit_code, 2);
  EXPECT_NE(no_beliefs.output.find("no bsf_vpr/Belief"), std::string::npos) << no_beliefs.output;

  std::ofstream(dir_ + "/poses.csv") << "query,x,y,z,yaw\n0,1,2,3\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {mk_ref + " --images " + dir_ + " --name x --out " + dir_ + "/x.yaml", "no image files"},
      {mk_ref + " --descriptors " + kGardens + "day_left.npy --out " + dir_ + "/x.yaml", "--name"},
      {mk_ref + " --descriptors " + kGardens + "day_left.npy --name x --out " + dir_ + "/x.npy",
       ".yaml"},
      {mk_ref + " --images a --descriptors b --name x --out x.yaml", "exactly one"},
      {mk_bag + " --descriptors " + kGardens + "day_left.npy", "--out"},
      {mk_bag + " --descriptors " + kGardens + "day_left.npy --out " + dir_ + "/b.bag --rate 0",
       "--rate"},
      {mk_bag + " --descriptors " + kGardens + "day_left.npy --out " + dir_ + "/b.bag --poses " +
           dir_ + "/poses.csv",
       "query,x,y,z,yaw"},
      {mk_bag + " --images /nonexistent --out " + dir_ + "/b.bag", "/nonexistent"},
      {std::string(BSF_EVALUATE_PATH) + " --results-bag /nonexistent.bag",
       "cannot read results bag"},
      {std::string(BSF_EVALUATE_PATH) + " --results-bag x.bag --reference a=" + kGardens +
           "day_left.npy",
       "--results-bag goes without"},
  };
  for (const auto& [command, fragment] : cases) {
    const Result r = RunCommand(command);
    EXPECT_EQ(r.exit_code, 2) << command << "\n" << r.output;
    EXPECT_NE(r.output.find(fragment), std::string::npos) << command << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(dir_ + "/b.bag"));  // nothing half-written is left behind
  EXPECT_FALSE(fs::exists(dir_ + "/b.bag.tmp"));
}

TEST_F(MakeTools, ToolsCreateTheFoldersTheyWriteInto) {
  const std::string day = kGardens + "day_left.npy", night = kGardens + "night_right.npy";
  const Result bag = RunCommand(std::string(BSF_MAKE_BAG_PATH) + " --descriptors " + night +
                                " --tolerance 8 --limit 5 --out " + dir_ + "/a/b/night.bag");
  ASSERT_EQ(bag.exit_code, 0) << bag.output;
  EXPECT_TRUE(fs::is_regular_file(dir_ + "/a/b/night.bag"));
  const Result ref = RunCommand(std::string(BSF_MAKE_REFERENCE_PATH) + " --descriptors " + day +
                                " --name day --out " + dir_ + "/c/d/day.yaml");
  ASSERT_EQ(ref.exit_code, 0) << ref.output;
  EXPECT_TRUE(fs::is_regular_file(dir_ + "/c/d/day.yaml"));
  EXPECT_EQ(LoadReferenceSetYaml(dir_ + "/c/d/day.yaml").size(), 200);  // and its .npy
  const Result syn =
      RunCommand(std::string(BSF_MAKE_SYNTHETIC_PATH) + " --places 20 --out " + dir_ + "/e/f");
  ASSERT_EQ(syn.exit_code, 0) << syn.output;
  EXPECT_TRUE(fs::is_regular_file(dir_ + "/e/f/queries.npy"));
  const std::string in = "--reference day=" + day + " --query " + night +
                         " --distance cosine --tolerance 3 --methods bsf --no-progress --out ";
  const Result eval = Evaluate(in + dir_ + "/g/h");
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  EXPECT_TRUE(fs::is_regular_file(dir_ + "/g/h/summary.csv"));
  // A folder that cannot be made (a file is in the way): one line naming it, exit 2.
  std::ofstream(dir_ + "/file") << "x";
  const std::vector<std::string> commands = {
      std::string(BSF_MAKE_BAG_PATH) + " --descriptors " + night + " --out " + dir_ +
          "/file/sub/n.bag",
      std::string(BSF_MAKE_REFERENCE_PATH) + " --descriptors " + day + " --name day --out " + dir_ +
          "/file/sub/day.yaml",
      std::string(BSF_MAKE_SYNTHETIC_PATH) + " --places 20 --out " + dir_ + "/file/sub",
  };
  for (const std::string& command : commands) {
    ExpectOneLineRefusal(RunCommand(command), "cannot create folder '" + dir_ + "/file/sub'",
                         command);
  }
  const Result bad_eval = Evaluate(in + dir_ + "/file/sub");
  EXPECT_EQ(bad_eval.exit_code, 2);
  EXPECT_NE(bad_eval.output.find(dir_ + "/file/"), std::string::npos) << bad_eval.output;
}

// The first `count` images of a shipped Nordland season (of nordland_64x32, whose first 17
// frames are alike, or another folder of data/), copied into dir/season.
std::string CopyImages(const std::string& season, int count, const std::string& dir,
                       const std::string& data = "nordland_64x32") {
  const std::string from = kSource + "/data/" + data + "/" + season;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(from)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  const std::string to = dir + "/" + season;
  fs::create_directories(to);
  for (int k = 0; k < count && k < static_cast<int>(files.size()); ++k) {
    fs::copy_file(files[static_cast<size_t>(k)], to + "/" + files[k].filename().string());
  }
  return to;
}

std::vector<std::string> SortedFileNames(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(folder)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

TEST_F(MakeTools, MakeReferenceNamesEachRowsImage) {
  // Images below the YAML's folder are named relative to it; each row was described from
  // the file image_files lists for it: that file alone, described again, gives the row.
  const std::string summer = CopyImages("summer", 12, dir_ + "/sets", "nordland_subset100/64x32");
  const std::string mk_ref = std::string(BSF_MAKE_REFERENCE_PATH) +
                             " --patch-width-px 16 --patch-height-px 8 --patch-size-px 4 ";
  const Result made =
      RunCommand(mk_ref + "--images " + summer + "/ --name summer --out " + dir_ + "/sets/s.yaml");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const std::string text = ReadFile(dir_ + "/sets/s.yaml");
  EXPECT_NE(text.find("\nimages: summer\n"), std::string::npos) << text;
  const ReferenceSet set = LoadReferenceSetYaml(dir_ + "/sets/s.yaml");
  ASSERT_EQ(set.size(), 12);
  EXPECT_EQ(set.images, summer);
  ASSERT_EQ(set.image_files, SortedFileNames(summer));
  for (const int k : {0, 5, 11}) {
    const std::string one = dir_ + "/one_" + std::to_string(k);
    fs::create_directories(one);
    fs::copy_file(summer + "/" + set.image_files[static_cast<size_t>(k)], one + "/x.png");
    const Result r = RunCommand(mk_ref + "--images " + one + " --name one --out " + one + ".yaml");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const ReferenceSet alone = LoadReferenceSetYaml(one + ".yaml");
    EXPECT_EQ(alone.descriptors.row(0), set.descriptors.row(k)) << k;
    EXPECT_NE(alone.descriptors.row(0), set.descriptors.row(k == 0 ? 1 : k - 1)) << k;
  }
  // A set made from descriptors names no images.
  const Result npy = RunCommand(std::string(BSF_MAKE_REFERENCE_PATH) + " --descriptors " +
                                kGardens + "day_left.npy --name day --out " + dir_ + "/d.yaml");
  ASSERT_EQ(npy.exit_code, 0) << npy.output;
  EXPECT_EQ(ReadFile(dir_ + "/d.yaml").find("image"), std::string::npos);
}

TEST_F(MakeTools, MakeReferenceDescribesImagesAsTheEvaluatorDoes) {
  // 100 winter images as the reference, 100 summer images as queries. A set made with
  // HOG or an ONNX network (flags away from their defaults, a switch among them) must
  // give exactly the evaluator's own results for the image folder with the same flags.
  const std::string winter = CopyImages("winter", 100, dir_);
  const std::string summer = CopyImages("summer", 100, dir_);
  const std::string model = kSource + "/test/data/models/maxpool2d/model.onnx";
  const struct {
    std::string name, flags, distance, type;
    int dimension;
  } kDescribers[] = {
      {"hog",
       "--image-descriptor hog --hog-width-px 32 --hog-height-px 32 --hog-cell-px 8 --hog-bins 6",
       "cosine", "hog_32x32_c8_b6", 3 * 3 * 4 * 6},
      // Without L2 normalisation Euclidean distances depend on the norm: --onnx-no-l2 counts.
      {"onnx",
       "--image-descriptor onnx --onnx-model " + model +
           " --onnx-input-width-px 7 --onnx-input-height-px 7 --onnx-l2-normalize false",
       "euclidean", "onnx_model_48", 48},
      {"patchnorm", "--patch-width-px 32 --patch-height-px 16 --patch-size-px 4", "cosine",
       "patchnorm_32x16_p4", 32 * 16},
  };
  for (const auto& d : kDescribers) {
    const std::string yaml = dir_ + "/sets/" + d.name + ".yaml";
    const Result made =
        RunCommand(std::string(BSF_MAKE_REFERENCE_PATH) + " --images " + winter +
                   " --name winter --distance " + d.distance + " " + d.flags + " --out " + yaml);
    ASSERT_EQ(made.exit_code, 0) << made.output;
    EXPECT_NE(made.output.find(d.type), std::string::npos) << made.output;
    const ReferenceSet set = LoadReferenceSetYaml(yaml);
    EXPECT_EQ(set.descriptor_type, d.type);
    EXPECT_EQ(set.distance, d.distance);
    EXPECT_EQ(set.size(), 100);
    EXPECT_EQ(set.dimension(), d.dimension);
    // The YAML names the images (absolute: not below the YAML's folder), row k the k-th.
    const std::string text = ReadFile(yaml);
    EXPECT_NE(text.find("\nimages: " + winter + "\n"), std::string::npos) << text;
    EXPECT_NE(text.find("\nimage_files: [images-00010.png, images-00020.png, "), std::string::npos)
        << text;
    EXPECT_EQ(set.images, winter);
    EXPECT_EQ(set.image_files, SortedFileNames(winter));

    const std::string common = " --query " + summer + " --distance " + d.distance + " " + d.flags +
                               " --tolerance 2 --methods bsf,nn:winter --no-progress --out ";
    const Result from_set = Evaluate("--reference winter=" + yaml + common + dir_ + "/a_" + d.name);
    ASSERT_EQ(from_set.exit_code, 0) << from_set.output;
    const Result from_images =
        Evaluate("--reference winter=" + winter + common + dir_ + "/b_" + d.name);
    ASSERT_EQ(from_images.exit_code, 0) << from_images.output;
    const std::vector<std::string> summary = Lines(dir_ + "/a_" + d.name + "/summary.csv");
    ASSERT_EQ(summary.size(), 3u) << d.name;
    EXPECT_EQ(summary, Lines(dir_ + "/b_" + d.name + "/summary.csv")) << d.name;
    for (const char* m : {"bsf", "nn_winter"}) {
      const std::string matches = std::string("/matches/") + m + ".csv";
      EXPECT_EQ(Lines(dir_ + "/a_" + d.name + matches), Lines(dir_ + "/b_" + d.name + matches))
          << d.name << " " << m;
    }
  }
  // The flags are the evaluator's: the same checks, and descriptor flags need images.
  const std::string mk_ref =
      std::string(BSF_MAKE_REFERENCE_PATH) + " --name x --out " + dir_ + "/x/x.yaml ";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--images " + winter + " --image-descriptor sift",
       "--image-descriptor must be patchnorm | hog | onnx, got 'sift'"},
      {"--images " + winter + " --image-descriptor hog --hog-cell-px 7",
       "multiples of hog_cell_px"},
      {"--images " + winter + " --image-descriptor onnx", "onnx_model is empty"},
      {"--images " + winter + " --image-descriptor onnx --onnx-model /nonexistent.onnx",
       "/nonexistent.onnx"},
      {"--images " + winter + " --image-descriptor onnx --onnx-model " + model +
           " --onnx-input 7x7",
       "--onnx-input was renamed: use --onnx-input-width-px W --onnx-input-height-px H"},
      {"--images " + winter + " --hog-bins 0", "--hog-bins must be >= 1, got 0"},
      {"--descriptors " + kGardens + "day_left.npy --onnx-rgb false",
       "--onnx-rgb describes images"},
      {"--descriptors " + kGardens + "day_left.npy --image-descriptor hog",
       "--image-descriptor describes images: it goes with --images"},
      {"--descriptors " + kGardens + "day_left.npy --distance cosin",
       "--distance: distance must be euclidean or cosine, got 'cosin'"},
  };
  for (const auto& [args, fragment] : bad) {
    ExpectOneLineRefusal(RunCommand(mk_ref + args), fragment, args);
  }
  EXPECT_FALSE(fs::exists(dir_ + "/x"));
}

TEST_F(MakeTools, MakeSyntheticRefusesABadNumberList) {
  const Result syn =
      RunCommand(std::string(BSF_MAKE_SYNTHETIC_PATH) + " --out " + dir_ + "/s --set-noise 0.1,x");
  EXPECT_EQ(syn.exit_code, 2);
  EXPECT_NE(syn.output.find("--set-noise expects a number"), std::string::npos) << syn.output;
}

// The width and height a PNG's header declares.
std::pair<int, int> PngSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char h[24] = {};
  in.read(reinterpret_cast<char*>(h), sizeof h);
  const auto be = [&](int at) {
    return (h[at] << 24) | (h[at + 1] << 16) | (h[at + 2] << 8) | h[at + 3];
  };
  return {be(16), be(20)};
}

TEST_F(MakeTools, MakeViewsCropsEveryFrameSidewaysOrRefusesACropOutOfTheFrame) {
  const std::string tool = BSF_MAKE_VIEWS_PATH;
  const std::string frames = kSource + "/data/nordland_subset100/256x144/fall";
  const Result r =
      RunCommand(tool + " --images " + frames + " --out " + dir_ + "/left --shift -0.05");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("wrote 100 views"), std::string::npos) << r.output;
  ASSERT_TRUE(fs::exists(dir_ + "/left/000.png"));
  EXPECT_TRUE(fs::exists(dir_ + "/left/099.png"));
  EXPECT_EQ(PngSize(dir_ + "/left/000.png"), std::make_pair(179, 100));  // 70% of 256 x 144
  ASSERT_EQ(
      RunCommand(tool + " --images " + frames + " --out " + dir_ + "/half --crop 0.5").exit_code,
      0);
  EXPECT_EQ(PngSize(dir_ + "/half/000.png"), std::make_pair(128, 72));
  // Views from two sides are other images, not copies.
  std::ifstream a(dir_ + "/left/000.png", std::ios::binary),
      b(dir_ + "/half/000.png", std::ios::binary);
  const std::string bytes_a((std::istreambuf_iterator<char>(a)), {}),
      bytes_b((std::istreambuf_iterator<char>(b)), {});
  EXPECT_NE(bytes_a, bytes_b);
  ExpectOneLineRefusal(
      RunCommand(tool + " --images " + frames + " --out " + dir_ + "/x --shift 0.2"),
      "moves the crop out of the frame", "--shift 0.2");
  ExpectOneLineRefusal(
      RunCommand(tool + " --images " + frames + " --out " + dir_ + "/x --crop 1.5"),
      "--crop must be in (0, 1]", "--crop 1.5");
  ExpectOneLineRefusal(RunCommand(tool + " --images " + dir_ + "/nothing --out " + dir_ + "/x"),
                       "no folder", "a missing folder");
  EXPECT_FALSE(fs::exists(dir_ + "/x"));  // nothing written on a refusal
}

// A covered lens: dark, blurred, noisy views, whose scene is gone.
TEST_F(MakeTools, MakeViewsCoversTheLens) {
  const std::string tool = BSF_MAKE_VIEWS_PATH;
  const std::string frames = kSource + "/data/nordland_subset100/256x144/fall";
  const Result r = RunCommand(tool + " --images " + frames + " --out " + dir_ +
                              "/covered --crop 1 --cover true");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const cv::Mat frame = cv::imread(frames + "/010.jpg", cv::IMREAD_GRAYSCALE);
  const cv::Mat covered = cv::imread(dir_ + "/covered/010.png", cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(covered.size(), frame.size());
  cv::Scalar frame_mean, frame_sd, mean, sd;
  cv::meanStdDev(frame, frame_mean, frame_sd);
  cv::meanStdDev(covered, mean, sd);
  EXPECT_NEAR(mean[0], 0.05 * frame_mean[0], 2.0);  // darkened to 5%
  EXPECT_LT(sd[0], 3.0);                            // the sensor's noise and a slow gradient
  EXPECT_GT(sd[0], 1.0);                            // not a flat image
  ExpectOneLineRefusal(
      RunCommand(tool + " --images " + frames + " --out " + dir_ + "/x --cover yes"),
      "--cover takes true or false", "--cover yes");
  ExpectOneLineRefusal(
      RunCommand(tool + " --images " + frames + " --out " + dir_ + "/x --blind foggy"),
      "--blind takes covered, grey, black or dazzled", "--blind foggy");
}

// Every kind of blind view: its level, and the frame's scene gone (the image check says so).
TEST_F(MakeTools, MakeViewsMakesEveryKindOfBlindCamera) {
  const std::string tool = BSF_MAKE_VIEWS_PATH;
  const std::string frames = kSource + "/data/nordland_subset100/256x144/fall";
  const cv::Mat frame = cv::imread(frames + "/010.jpg", cv::IMREAD_COLOR);
  for (const auto& [kind, level] :
       std::vector<std::pair<std::string, double>>{{"covered", 0.05 * cv::mean(frame)[0]},
                                                   {"grey", 128},
                                                   {"black", 0.8},
                                                   {"dazzled", 250}}) {
    const Result r = RunCommand(tool + " --images " + frames + " --out " + dir_ + "/" + kind +
                                " --crop 1 --blind " + kind);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const cv::Mat view = cv::imread(dir_ + "/" + kind + "/010.png", cv::IMREAD_COLOR);
    ASSERT_EQ(view.size(), frame.size()) << kind;
    EXPECT_NEAR(cv::mean(view)[0], level, 3.0) << kind;
    EXPECT_NE(BlindImageProblem(view), "") << kind;
  }
  EXPECT_EQ(BlindImageProblem(frame), "");
  // A reference set described from them is written, with a warning naming the first.
  const Result ref = RunCommand(std::string(BSF_MAKE_REFERENCE_PATH) + " --images " + dir_ +
                                "/grey --name grey --out " + dir_ + "/grey.yaml");
  ASSERT_EQ(ref.exit_code, 0) << ref.output;
  EXPECT_NE(ref.output.find("warning: 100 of the 100 images show nothing (first: 000.png, "
                            "which shows only noise"),
            std::string::npos)
      << ref.output;
  EXPECT_TRUE(fs::exists(dir_ + "/grey.yaml"));
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

// bsf_store_set writes Gardens Point's day set (real HDC-DELF) as an int8 map holds it;
// bsf_evaluate then gives the same table whether it maps the stored set or reads and encodes
// the original (the rows and scale are bitwise the same).
TEST_F(MakeTools, StoreSetWritesInt8SetsThatEvaluateMapsToTheSameResults) {
  const std::string tool = BSF_STORE_SET_PATH;
  // What a killed run left for this OUT goes; another set's temporary stays.
  const std::string stale = dir_ + "/.day_left.int8.000000000000.npy.bsf_tmp.abcdefgh";
  const std::string other = dir_ + "/.night.int8.000000000000.npy.bsf_tmp.abcdefgh";
  std::ofstream(stale) << "partial";
  std::ofstream(other) << "partial";
  for (const std::string set : {"day_left"}) {
    const Result r = RunCommand(tool + " --set " + kGardens + set + ".npy --out " + dir_ + "/" +
                                set + ".yaml --storage int8");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("int8"), std::string::npos) << r.output;
    std::vector<std::string> rows;  // day_left.int8.<content hash>.npy
    for (const auto& e : fs::directory_iterator(dir_)) {
      if (e.path().filename().string().rfind(set + ".int8.", 0) == 0) rows.push_back(e.path());
    }
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_EQ(fs::file_size(rows[0]), 128u + 200u * 4096u);
    EXPECT_FALSE(fs::exists(stale));
    EXPECT_TRUE(fs::exists(other));
  }
  const std::string common =
      " --query " + kGardens + "night_right.npy --tolerance 2 --storage int8";
  const Result read = Evaluate("--reference day=" + kGardens + "day_left.npy" + common + " --out " +
                               dir_ + "/read");
  ASSERT_EQ(read.exit_code, 0) << read.output;
  const Result mapped = Evaluate("--reference day=" + dir_ + "/day_left.yaml" + common +
                                 " --memory-map true --out " + dir_ + "/mapped");
  ASSERT_EQ(mapped.exit_code, 0) << mapped.output;
  EXPECT_EQ(Lines(dir_ + "/read/summary.csv"), Lines(dir_ + "/mapped/summary.csv"));

  ExpectOneLineRefusal(RunCommand(tool + " --set " + kGardens + "day_left.npy --out " + dir_ +
                                  "/x.yaml --storage int4"),
                       "int4", "a bad storage");
  ExpectOneLineRefusal(
      RunCommand(tool + " --set " + dir_ + "/missing.yaml --out " + dir_ + "/x.yaml"),
      "missing.yaml", "a missing set");
  ExpectOneLineRefusal(RunCommand(tool + " --out " + dir_ + "/x.yaml"), "--set and --out",
                       "no set");
  ExpectOneLineRefusal(
      Evaluate("--reference day=" + dir_ + "/day_left.yaml" + common + " --memory-map yes"),
      "--memory-map takes true or false", "a bad --memory-map");
}

}  // namespace
}  // namespace bsf_vpr
