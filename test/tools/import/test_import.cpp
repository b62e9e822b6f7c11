// bsf_import end to end, in each dataset layout, on fixtures made here at test time from the
// real Nordland images shipped in data/ with SYNTHETIC trajectories (import_fixtures.h:
// stops, speed changes, a detour, a reversed stretch). The images do not show the places the
// trajectories claim; what is tested is the geometry (places, shared ids, uncovered places),
// the timing, the poses and ground truth in the bags and the demosaicing (the errors:
// test_import_errors.cpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "bsf_vpr/image/image_describer.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/tools/import/import_traversal.h"
#include "test/core/enum_names_check.h"
#include "test/tools/import/import_fixtures.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;
using testing::BagContents;
using testing::kEpochUs;
using testing::kLat0;
using testing::kLon0;
using testing::kPi;
using testing::ReadBag;
using testing::Result;
using testing::TimedPose;
using Import = testing::ImportTest;

// The planar distance of two poses.
double Dist(const PlacePose& a, const PlacePose& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m);
}

// The first reference makes a place every metre of its 80.5 m route (the stop adds none), each
// at its frame's pose.
void ExpectPlacesEveryMetre(const ReferenceSet& a) {
  ASSERT_EQ(a.size(), testing::kRouteAPlaces);
  for (int k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a.place_ids[static_cast<size_t>(k)], k);
    if (k == 0) continue;
    const double d = Dist(a.poses[static_cast<size_t>(k)], a.poses[static_cast<size_t>(k - 1)]);
    EXPECT_GT(d, 0.6) << "place " << k;
    EXPECT_LT(d, 1.4) << "place " << k;
  }
  EXPECT_NEAR(a.poses.front().x_m, 0, 1e-6);
  EXPECT_NEAR(a.poses[30].x_m, 30, 0.3);
  EXPECT_NEAR(a.poses.back().y_m, 20, 0.3);
}

// The second reference shares the first's place ids (its frame for a place lies within the
// association radius, 5 m, and 45 degrees of the place: it was seen there), covers what it
// drives and leaves the rest uncovered; without --add-new-places it adds nothing.
void ExpectSharedAndUncovered(const ReferenceSet& a, const ReferenceSet& b) {
  const std::set<int> ids(b.place_ids.begin(), b.place_ids.end());
  for (size_t k = 0; k < b.place_ids.size(); ++k) {
    const int id = b.place_ids[k];
    ASSERT_LT(id, a.size());
    const PlacePose& place = a.poses[static_cast<size_t>(id)];
    EXPECT_LE(Dist(b.poses[k], place), 5.0) << "place " << id;
    EXPECT_LE(testing::AngleBetween(b.poses[k].yaw_rad, place.yaw_rad), kPi / 4 + 1e-9) << id;
  }
  // On the straight stretches it drives east the nearest frame is within half a frame step.
  for (int id = 12; id <= 28; ++id) {
    const size_t k = static_cast<size_t>(std::find(b.place_ids.begin(), b.place_ids.end(), id) -
                                         b.place_ids.begin());
    ASSERT_LT(k, b.place_ids.size()) << id;
    EXPECT_LE(Dist(b.poses[k], a.poses[static_cast<size_t>(id)]), 0.4) << id;
  }
  for (int id = 0; id <= 3; ++id) EXPECT_EQ(ids.count(id), 0u) << id;  // before its start
  for (int id = 10; id <= 58; ++id) {  // driven east; place 50 lies 5 m from both ends of
    if (id != 50) {                    // the detour, on the radius
      EXPECT_EQ(ids.count(id), 1u) << id;
    }
  }
  for (int id = 66; id <= 80; ++id) EXPECT_EQ(ids.count(id), 0u) << id;  // the northern leg
}

// Query bag: per frame an input message, its ground truth and pose, in that order, at the
// frame's stamp; ground truth = the places within `tolerance_m` of the pose.
void ExpectQueryBag(const BagContents& bag, const std::vector<TimedPose>& drive,
                    const std::vector<std::optional<PlacePose>>& places, double tolerance_m,
                    double position_tolerance_m) {
  ASSERT_EQ(bag.poses.size(), drive.size());
  ASSERT_EQ(bag.truths.size(), drive.size());
  ASSERT_EQ(bag.topics.size(), 3 * drive.size());
  EXPECT_EQ(std::count(bag.topics.begin(), bag.topics.end(), "/camera/image_raw"),
            static_cast<long>(drive.size()));
  for (size_t k = 0; k < drive.size(); ++k) {
    const geometry_msgs::PoseStamped& p = bag.poses[k];
    EXPECT_EQ(p.header.frame_id, "map");
    EXPECT_NEAR(p.pose.position.x, drive[k].pose.x_m, position_tolerance_m) << k;
    EXPECT_NEAR(p.pose.position.y, drive[k].pose.y_m, position_tolerance_m) << k;
    EXPECT_EQ(bag.truths[k].query_index, static_cast<int>(k));
    EXPECT_EQ(bag.truths[k].header.stamp, p.header.stamp);
    EXPECT_EQ(bag.images.at(k).header.stamp, p.header.stamp);
    std::vector<int> expected;  // brute force
    for (size_t i = 0; i < places.size(); ++i) {
      if (places[i] && std::hypot(places[i]->x_m - p.pose.position.x,
                                  places[i]->y_m - p.pose.position.y) <= tolerance_m) {
        expected.push_back(static_cast<int>(i));
      }
    }
    EXPECT_EQ(bag.truths[k].correct_places, expected) << k;
    EXPECT_FALSE(expected.empty()) << k;
  }
}

// The place index of an import: place -> pose, from its reference sets (the first set that
// has a place made it: its pose is the place's).
std::vector<std::optional<PlacePose>> IndexOf(const std::vector<ReferenceSet>& sets) {
  std::vector<std::optional<PlacePose>> index;
  for (const ReferenceSet& s : sets) {
    for (size_t k = 0; k < s.place_ids.size(); ++k) {
      const size_t id = static_cast<size_t>(s.place_ids[k]);
      if (index.size() <= id) index.resize(id + 1);
      if (!index[id]) index[id] = s.poses[k];
    }
  }
  return index;
}

// Each row of `set` names, below `folder`, the frame it was described from: describing
// that file again (demosaiced with `bayer_code`, resized to `resize` as the import did) gives
// the row, and the file's frame lies at the row's pose (`frame_poses`: file name -> its
// frame's pose in the map frame; empty for a set without poses).
void ExpectRowsNameTheirFrames(const ReferenceSet& set, const std::string& folder,
                               const std::map<std::string, PlacePose>& frame_poses,
                               double tolerance_m, int bayer_code = -1, cv::Size resize = {}) {
  EXPECT_EQ(set.images, folder);
  ASSERT_EQ(set.image_files.size(), static_cast<size_t>(set.size()));
  const auto describer = MakeImageDescriber(ImageDescriberOptions());
  tools::Traversal t;
  t.bayer_code = bayer_code;
  for (size_t k = 0; k < set.image_files.size(); ++k) {
    const std::string& file = set.image_files[k];
    if (!frame_poses.empty()) {
      const auto frame = frame_poses.find(file);
      ASSERT_NE(frame, frame_poses.end()) << file;
      EXPECT_LE(Dist(frame->second, set.poses[k]), tolerance_m) << "row " << k << ": " << file;
    }
    tools::Frame f;
    f.image = folder + "/" + file;
    const Eigen::VectorXf d = describer->Describe(tools::LoadFrameImage(t, f, resize));
    EXPECT_EQ(set.descriptors.row(static_cast<Eigen::Index>(k)), d.transpose()) << k << file;
  }
}

// The layouts and pose coordinates have one table of names each.
TEST(ImportNames, EveryEnumerationsNamesRoundTrip) {
  testing::ExpectNamesRoundTrip(tools::DatasetFoldersNames(), tools::ParseDatasetFolders, "--layout");
  testing::ExpectNamesRoundTrip<tools::PoseCoordinates>(tools::PoseCoordinatesNames(), nullptr,
                                                        "pose coordinates");
  EXPECT_EQ(tools::ToString(tools::PoseCoordinates::kUtm), "UTM poses");
}

TEST(ImportBayer, OpenCvCodesDemosaicTheSdkPatterns) {
  // The SDK's patterns ('gbrg' stereo, 'rggb' mono: filters at (0,0), (0,1), (1,0), (1,1))
  // mosaic a known colour; the code bsf_import uses must give that colour back, and the
  // other camera's code must not (so that a swapped constant fails here).
  const cv::Mat colour(16, 16, CV_8UC3, cv::Scalar(30, 140, 220));  // B, G, R
  for (const auto& [camera, pattern, other] :
       {std::tuple<std::string, std::string, std::string>{"stereo/centre", "gbrg", "mono_left"},
        {"mono_rear", "rggb", "stereo/left"}}) {
    cv::Mat back, wrong;
    cv::cvtColor(testing::Mosaic(colour, pattern), back, tools::RobotCarBayerCode(camera));
    cv::cvtColor(testing::Mosaic(colour, pattern), wrong, tools::RobotCarBayerCode(other));
    const cv::Vec3b c = back.at<cv::Vec3b>(8, 8), w = wrong.at<cv::Vec3b>(8, 8);
    EXPECT_EQ(std::vector<int>({c[0], c[1], c[2]}), std::vector<int>({30, 140, 220})) << pattern;
    EXPECT_GT(std::abs(w[0] - 30) + std::abs(w[1] - 140) + std::abs(w[2] - 220), 100) << pattern;
  }
  EXPECT_THROW(tools::RobotCarBayerCode("lms_front"), std::invalid_argument);
  // A real image (a Nordland frame, 256x144) comes back close to itself through the file.
  const cv::Mat real =
      cv::imread(std::string(BSF_SOURCE_DIR) + "/data/nordland_subset100/256x144/summer/000.jpg");
  char tmpl[] = "/tmp/bsf_bayer_XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  tools::Traversal t;
  t.bayer_code = tools::RobotCarBayerCode("stereo/centre");
  tools::Frame f;
  f.image = dir + "/1.png";
  cv::imwrite(f.image, testing::Mosaic(real, "gbrg"));
  const cv::Mat back = tools::LoadFrameImage(t, f, cv::Size());
  t.bayer_code = tools::RobotCarBayerCode("mono_left");
  const cv::Mat wrong = tools::LoadFrameImage(t, f, cv::Size());
  const double error = cv::norm(back, real, cv::NORM_L1) / real.total();
  EXPECT_LT(error, 0.5 * cv::norm(wrong, real, cv::NORM_L1) / real.total());
  const cv::Scalar mean = cv::mean(real), back_mean = cv::mean(back);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(back_mean[c], mean[c], 2) << c;
  fs::remove_all(dir);
}

TEST_F(Import, RobotCarTraversalsToSetsOnOnePlaceIndexAndABag) {
  const std::string day = testing::WriteRobotCar(dir_, "2014-05-14-13-46-12", testing::RouteA(0.25),
                                                 testing::RouteA(0.07), "summer", kEpochUs);
  const std::string night =
      testing::WriteRobotCar(dir_, "2014-12-10-18-10-50", testing::RouteB(0.25),
                             testing::RouteB(0.07), "winter", kEpochUs + 50000000);
  const std::vector<TimedPose> dusk_drive = testing::RouteQ(0.25);
  const std::string dusk =
      testing::WriteRobotCar(dir_, "2015-02-03-08-45-10", dusk_drive, testing::RouteQ(0.07),
                             "summer", kEpochUs + 900000000);
  const Result r = Run("--layout robotcar --reference day=" + day + " --reference night=" + night +
                       " --query dusk=" + dusk + " --condition night=dark --resize 32x16 --out " +
                       dir_ + "/out");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2 frames without a pose skipped; 3 timestamps without an image"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("UTM easting 620000"), std::string::npos) << r.output;
  const ReferenceSet a = LoadReferenceSetYaml(dir_ + "/out/day.yaml");
  const ReferenceSet b = LoadReferenceSetYaml(dir_ + "/out/night.yaml");
  EXPECT_EQ(a.condition, "day");
  EXPECT_EQ(b.condition, "dark");
  EXPECT_EQ(a.descriptor_type, "patchnorm_64x32_p8");
  ExpectPlacesEveryMetre(a);
  ExpectSharedAndUncovered(a, b);
  // Each row names its raw image: <microseconds>.png of the frame at the row's pose.
  const auto frames = [](const std::vector<TimedPose>& drive, int64_t t0_us) {
    std::map<std::string, PlacePose> by_file;
    for (const TimedPose& f : drive) {
      by_file[std::to_string(t0_us + std::llround(f.t_s * 1e6)) + ".png"] = f.pose;
    }
    return by_file;
  };
  const int bayer = tools::RobotCarBayerCode("stereo/centre");
  ExpectRowsNameTheirFrames(a, day + "/stereo/centre", frames(testing::RouteA(0.25), kEpochUs),
                            0.25, bayer, cv::Size(32, 16));
  ExpectRowsNameTheirFrames(b, night + "/stereo/centre",
                            frames(testing::RouteB(0.25), kEpochUs + 50000000), 0.25, bayer,
                            cv::Size(32, 16));
  // The INS yaw (clockwise from north) became the map frame's heading (counter-clockwise
  // from east): east along the first legs, north (pi/2) on the last.
  EXPECT_NEAR(a.poses[15].yaw_rad, 0, 1e-6);
  EXPECT_NEAR(a.poses[70].yaw_rad, kPi / 2, 1e-6);

  const BagContents bag = ReadBag(dir_ + "/out/dusk.bag");
  ExpectQueryBag(bag, dusk_drive, IndexOf({a, b}), 10, 0.25);
  ASSERT_EQ(bag.images.size(), dusk_drive.size());
  for (size_t k = 0; k < bag.images.size(); ++k) {
    // The original stamps (microseconds of the file names), not a rate.
    const int64_t us = kEpochUs + 900000000 + std::llround(dusk_drive[k].t_s * 1e6);
    EXPECT_EQ(bag.images[k].header.stamp.toNSec(), static_cast<uint64_t>(us) * 1000) << k;
    EXPECT_EQ(bag.images[k].width, 32u);
    EXPECT_EQ(bag.images[k].height, 16u);
    EXPECT_EQ(bag.images[k].encoding, "bgr8");
    // Heading along the legs (not at the corners, where the INS samples straddle two legs).
    if (k > 0 && k + 1 < dusk_drive.size() &&
        dusk_drive[k - 1].pose.yaw_rad == dusk_drive[k + 1].pose.yaw_rad) {
      EXPECT_LT(testing::AngleBetween(testing::YawOf(bag.poses[k]), dusk_drive[k].pose.yaw_rad),
                1e-6)
          << k;
    }
  }
  // The images are demosaiced colour: close to the Nordland frames they were made from.
  const cv::Mat first(16, 32, CV_8UC3, const_cast<uint8_t*>(bag.images[0].data.data()));
  cv::Mat original;
  cv::resize(cv::imread(testing::NordlandImages("summer", 3)[2]), original, cv::Size(32, 16), 0, 0,
             cv::INTER_AREA);
  EXPECT_LT(cv::norm(first, original, cv::NORM_L1) / original.total(), 30.0);
}

TEST_F(Import, RobotCarDetourAndReversedStretchAddPlaces) {
  const std::string day = testing::WriteRobotCar(dir_, "d1", testing::RouteA(0.25),
                                                 testing::RouteA(0.07), "summer", kEpochUs);
  const std::string night = testing::WriteRobotCar(
      dir_, "d2", testing::RouteB(0.25), testing::RouteB(0.07), "winter", kEpochUs + 50000000);
  const Result r = Run("--layout robotcar --reference day=" + day + " --reference night=" + night +
                       " --add-new-places true --out " + dir_ + "/out");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ReferenceSet a = LoadReferenceSetYaml(dir_ + "/out/day.yaml");
  const ReferenceSet b = LoadReferenceSetYaml(dir_ + "/out/night.yaml");
  int added = 0;
  for (size_t k = 0; k < b.place_ids.size(); ++k) {
    if (b.place_ids[k] < a.size()) continue;
    EXPECT_EQ(b.place_ids[k], a.size() + added);  // numbered after the first set's places
    ++added;
    // Each new place lies on the detour (away from the route, or on it heading off it) or
    // on the reversed stretch: farther than 5 m or more than 45 degrees from every place.
    const PlacePose& p = b.poses[k];
    EXPECT_TRUE(p.y_m > 5 || testing::AngleBetween(p.yaw_rad, 0) > kPi / 4)
        << p.x_m << " " << p.y_m << " " << p.yaw_rad;
  }
  EXPECT_GT(added, 40);  // the detour is 60 m long, the reversed stretch 20 m
  EXPECT_NE(r.output.find("adds " + std::to_string(added)), std::string::npos) << r.output;
}

TEST_F(Import, NordlandFramesWithGpsLogs) {
  // Summer: a fix per frame ('frame' column). Winter: fixes once a second ('timestamp'
  // column; frames between are interpolated), ending 2 s before its last frame.
  const std::vector<TimedPose> a_drive = testing::RouteA(0.25), b_drive = testing::RouteB(0.25),
                               q_drive = testing::RouteQ(0.25);
  const std::string summer = testing::WriteNordlandFrames(dir_, "summer", a_drive.size(), "summer");
  const std::string winter = testing::WriteNordlandFrames(dir_, "winter", b_drive.size(), "winter");
  const std::string query = testing::WriteNordlandFrames(dir_, "spring", q_drive.size(), "summer");
  std::ofstream a_gps(dir_ + "/summer.csv"), b_gps(dir_ + "/winter.csv"), q_gps(dir_ + "/q.csv");
  a_gps.precision(12), b_gps.precision(12), q_gps.precision(12);
  a_gps << "frame,latitude,longitude\n";
  q_gps << "frame,lat,lon\n";
  b_gps << "timestamp,latitude,longitude,speed\n";
  double lat = 0, lon = 0;
  for (size_t k = 0; k < a_drive.size(); ++k) {
    testing::LatLonOf(a_drive[k].pose, kLat0, kLon0, &lat, &lon);
    a_gps << 100 + k << "," << lat << "," << lon << "\n";
  }
  for (size_t k = 0; k < q_drive.size(); ++k) {
    testing::LatLonOf(q_drive[k].pose, kLat0, kLon0, &lat, &lon);
    q_gps << 100 + k << "," << lat << "," << lon << "\n";
  }
  for (size_t k = 0; k + 8 < b_drive.size(); k += 4) {  // frame 100 + k is at 25 + k / 4 s
    testing::LatLonOf(b_drive[k].pose, kLat0, kLon0, &lat, &lon);
    b_gps << 25 + b_drive[k].t_s << "," << lat << "," << lon << ",20\n";
  }
  a_gps.close(), b_gps.close(), q_gps.close();
  const Result r = Run("--layout nordland --frame-rate-hz 4 --reference summer=" + summer + "," +
                       dir_ + "/summer.csv --reference winter=" + winter + "," + dir_ +
                       "/winter.csv --query spring=" + query + "," + dir_ + "/q.csv --out " + dir_ +
                       "/out --distance cosine");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("latitude 67.28, longitude 14.4"), std::string::npos) << r.output;
  const size_t skipped = b_drive.size() - 1 - 4 * ((b_drive.size() - 9) / 4);
  EXPECT_NE(r.output.find(std::to_string(skipped) + " frames without a pose skipped"),
            std::string::npos)
      << r.output;
  const ReferenceSet a = LoadReferenceSetYaml(dir_ + "/out/summer.yaml");
  const ReferenceSet b = LoadReferenceSetYaml(dir_ + "/out/winter.yaml");
  EXPECT_EQ(a.distance, "cosine");
  ExpectPlacesEveryMetre(a);
  ExpectSharedAndUncovered(a, b);
  // Each row names its frame, images-<100 + k>.png at the row's pose: frame k's, or for
  // winter interpolated between the fixes of every fourth frame, as the import does.
  const auto frames = [](const std::vector<TimedPose>& drive, size_t fix_every) {
    std::map<std::string, PlacePose> by_file;
    for (size_t k = 0; k < drive.size(); ++k) {
      const size_t k0 = k - k % fix_every, k1 = std::min(k0 + fix_every, drive.size() - 1);
      const double f = static_cast<double>(k - k0) / static_cast<double>(fix_every);
      PlacePose p = drive[k0].pose;
      p.x_m += f * (drive[k1].pose.x_m - p.x_m);
      p.y_m += f * (drive[k1].pose.y_m - p.y_m);
      char file[32];
      std::snprintf(file, sizeof(file), "images-%05zu.png", 100 + k);
      by_file[file] = p;
    }
    return by_file;
  };
  ExpectRowsNameTheirFrames(a, summer, frames(a_drive, 1), 1e-3);
  ExpectRowsNameTheirFrames(b, winter, frames(b_drive, 4), 1e-3);
  EXPECT_NEAR(a.poses[15].yaw_rad, 0, 1e-6);  // headings from the path
  EXPECT_NEAR(a.poses[70].yaw_rad, kPi / 2, 1e-6);
  const BagContents bag = ReadBag(dir_ + "/out/spring.bag");
  ExpectQueryBag(bag, q_drive, IndexOf({a, b}), 10, 1e-3);
  for (size_t k = 0; k < bag.images.size(); ++k) {
    // Frame 100 + k at (100 + k) / 4 s, after 1000 s.
    EXPECT_EQ(bag.images[k].header.stamp, ros::Time(1000 + (100 + k) / 4.0)) << k;
  }
}

TEST_F(Import, NordlandFrameAlignedWithoutGps) {
  const std::string n100 = std::string(BSF_SOURCE_DIR) + "/data/nordland_subset100/64x32/";
  const Result r = Run("--layout nordland --reference summer=" + n100 +
                       "summer --reference fall=" + n100 + "fall --query winter=" + n100 +
                       "winter --query-descriptors true --rate-hz 10 --out " + dir_ + "/out");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ReferenceSet fall = LoadReferenceSetYaml(dir_ + "/out/fall.yaml");
  ASSERT_EQ(fall.size(), 100);
  EXPECT_TRUE(fall.poses.empty());
  for (int k = 0; k < 100; ++k) {
    EXPECT_EQ(fall.place_ids[static_cast<size_t>(k)], k);
    char file[16];
    std::snprintf(file, sizeof(file), "%03d.png", k);
    EXPECT_EQ(fall.image_files.at(static_cast<size_t>(k)), file);  // frame k = place k
  }
  ExpectRowsNameTheirFrames(fall, n100 + "fall", {}, 0);
  const std::string yaml = ReadFile(dir_ + "/out/fall.yaml");
  EXPECT_NE(yaml.find("\nimages: " + n100 + "fall\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("\nimage_files: [000.png, 001.png, "), std::string::npos) << yaml;
  const BagContents bag = ReadBag(dir_ + "/out/winter.bag");
  ASSERT_EQ(bag.descriptors.size(), 100u);
  EXPECT_TRUE(bag.poses.empty());
  EXPECT_EQ(std::count(bag.topics.begin(), bag.topics.end(), "/vpr/descriptor"), 100);
  const auto describer = MakeImageDescriber(ImageDescriberOptions());
  for (int k = 0; k < 100; ++k) {
    const Descriptor& d = bag.descriptors[static_cast<size_t>(k)];
    EXPECT_EQ(d.header.stamp, ros::Time(1000 + k / 10.0));
    std::vector<int> expected;
    for (int p = std::max(0, k - 2); p <= std::min(99, k + 2); ++p) expected.push_back(p);
    EXPECT_EQ(bag.truths[static_cast<size_t>(k)].correct_places, expected);
    char file[16];
    std::snprintf(file, sizeof(file), "%03d.png", k);
    const Eigen::VectorXf want = describer->Describe(cv::imread(n100 + "winter/" + file));
    ASSERT_EQ(d.data.size(), static_cast<size_t>(want.size()));
    EXPECT_TRUE(std::equal(d.data.begin(), d.data.end(), want.data())) << k;
    EXPECT_EQ(d.descriptor_type, "patchnorm_64x32_p8");
  }
}

TEST_F(Import, GenericImagesAndDescriptorsWithPoseFiles) {
  // Images with timestamp,x,y,z,yaw (seconds since the epoch, map frame).
  const std::vector<TimedPose> a_drive = testing::RouteA(0.25), q_drive = testing::RouteQ(0.25);
  const std::vector<std::string> images = testing::NordlandImages("winter", a_drive.size());
  fs::create_directories(dir_ + "/a");
  std::ofstream a_csv(dir_ + "/a.csv"), q_csv(dir_ + "/q.csv");
  a_csv.precision(16), q_csv.precision(16);
  a_csv << "timestamp,x,y,z,yaw\n";
  for (size_t k = 0; k < a_drive.size(); ++k) {
    fs::copy_file(images[k], dir_ + "/a/" + fs::path(images[k]).filename().string());
    const PlacePose& p = a_drive[k].pose;
    a_csv << 1.4e9 + a_drive[k].t_s << "," << p.x_m << "," << p.y_m << ",0," << p.yaw_rad << "\n";
  }
  a_csv.close();
  const Result r = Run("--layout generic --reference a=" + dir_ + "/a," + dir_ +
                       "/a.csv --query b=" + dir_ + "/a," + dir_ + "/a.csv --out " + dir_ + "/out");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ReferenceSet a = LoadReferenceSetYaml(dir_ + "/out/a.yaml");
  ExpectPlacesEveryMetre(a);
  std::map<std::string, PlacePose> frames;  // image k of the folder is the CSV's row k
  for (size_t k = 0; k < a_drive.size(); ++k) {
    frames[fs::path(images[k]).filename().string()] = a_drive[k].pose;
  }
  ExpectRowsNameTheirFrames(a, dir_ + "/a", frames, 1e-9);
  const BagContents bag = ReadBag(dir_ + "/out/b.bag");
  ExpectQueryBag(bag, a_drive, IndexOf({a}), 10, 1e-9);
  for (size_t k = 0; k < bag.images.size(); ++k) {
    EXPECT_NEAR(bag.images[k].header.stamp.toSec(), 1.4e9 + a_drive[k].t_s, 1e-6);
  }

  // Descriptor .npy files with timestamp,lat,lon: the real Gardens Point descriptors, a
  // synthetic straight drive north-east at 0.5 m per row.
  const std::string gardens = std::string(BSF_SOURCE_DIR) + "/data/gardens_point_hdc_delf/";
  std::ofstream g_csv(dir_ + "/g.csv");
  g_csv.precision(12);
  g_csv << "timestamp,lat,lon\n";
  for (int k = 0; k < 200; ++k) {
    double lat = 0, lon = 0;
    testing::LatLonOf(PlacePose{0.3 * k, 0.4 * k, 0, 0}, kLat0, kLon0, &lat, &lon);
    g_csv << 100 + k << "," << lat << "," << lon << "\n";
  }
  g_csv.close();
  const Result g = Run("--layout generic --reference day=" + gardens + "day_left.npy," + dir_ +
                       "/g.csv --query night=" + gardens + "night_right.npy," + dir_ +
                       "/g.csv --tolerance-m 2 --out " + dir_ + "/g");
  ASSERT_EQ(g.exit_code, 0) << g.output;
  const ReferenceSet day = LoadReferenceSetYaml(dir_ + "/g/day.yaml");
  const RowMatrixXf rows = ReadNpyMatrix(gardens + "day_left.npy");
  ASSERT_EQ(day.size(), 100);  // 99.5 m: places at rows 0, 2, ..., 198
  EXPECT_TRUE(day.descriptor_type.empty());
  EXPECT_TRUE(day.images.empty());  // a .npy has no images to name
  EXPECT_TRUE(day.image_files.empty());
  for (int k = 0; k < 100; ++k) {
    EXPECT_EQ(day.descriptors.row(k), rows.row(2 * k)) << k;
    EXPECT_NEAR(day.poses[static_cast<size_t>(k)].yaw_rad, std::atan2(0.4, 0.3), 1e-4);
  }
  const BagContents night = ReadBag(dir_ + "/g/night.bag");
  const RowMatrixXf queries = ReadNpyMatrix(gardens + "night_right.npy");
  ASSERT_EQ(night.descriptors.size(), 200u);
  for (int k = 0; k < 200; ++k) {
    const Descriptor& d = night.descriptors[static_cast<size_t>(k)];
    EXPECT_TRUE(std::equal(d.data.begin(), d.data.end(), queries.row(k).data())) << k;
    EXPECT_EQ(d.header.stamp, ros::Time(100.0 + k));
    // Within 2 m of a point every 0.5 m: the places at rows k/2 +- 2 (1 m apart).
    for (int p : night.truths[static_cast<size_t>(k)].correct_places)
      EXPECT_LE(std::abs(2 * p - k), 4) << k;
  }
}

TEST_F(Import, TheSummarySaysTheSpacingThePlacesHave) {
  // Frames 2 m apart with the default --place-spacing-m 1: each place is a frame, 2 m apart,
  // and the summary says so (it used to say "every 1 m").
  const std::vector<std::string> images = testing::NordlandImages("winter", 20);
  fs::create_directories(dir_ + "/s");
  std::ofstream csv(dir_ + "/s.csv");
  csv << "timestamp,x,y,z,yaw\n";
  for (size_t k = 0; k < images.size(); ++k) {
    fs::copy_file(images[k], dir_ + "/s/" + fs::path(images[k]).filename().string());
    csv << 1000 + k << "," << 2.0 * k << ",0,0,0\n";
  }
  csv.close();
  const Result r = Run("--layout generic --reference s=" + dir_ + "/s," + dir_ + "/s.csv --out " +
                       dir_ + "/sout");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(LoadReferenceSetYaml(dir_ + "/sout/s.yaml").size(), 20);
  EXPECT_NE(r.output.find("20 places one every 2 m (median)"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("every 1 m"), std::string::npos) << r.output;
  // Frames denser than the spacing: the spacing asked for.
  const Result dense = Run("--layout generic --reference s=" + dir_ + "/s," + dir_ +
                           "/s.csv --place-spacing-m 4 --out " + dir_ + "/dense");
  ASSERT_EQ(dense.exit_code, 0) << dense.output;
  EXPECT_NE(dense.output.find("places every 4 m"), std::string::npos) << dense.output;
}

}  // namespace
}  // namespace bsf_vpr
