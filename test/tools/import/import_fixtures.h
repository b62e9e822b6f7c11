// Fixtures for the bsf_import tests, made at test time in a temporary folder: the real
// Nordland images shipped in data/ laid out as each dataset layout expects, with SYNTHETIC
// trajectories (straight legs driven at given speeds, stops, a detour, a reversed stretch).
// The images do not show the places the trajectories say: these fixtures test the import's
// geometry, timing and files, not recognition.
#pragma once

#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/QueryGroundTruth.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "bsf_vpr/core/types.h"
#include "test/tools/tool_test_util.h"

namespace bsf_vpr {
namespace testing {

constexpr double kPi = 3.14159265358979323846;

// One leg of a drive: straight to (x, y) at speed_mps, then standing still for stop_s.
struct Leg {
  double x_m, y_m, speed_mps, stop_s;
};

struct TimedPose {
  double t_s;
  PlacePose pose;  // x east, y north, yaw counter-clockwise from east (the leg's heading)
};

// The drive from (x0, y0) along `legs`, sampled every dt_s from t = 0, and at its end.
inline std::vector<TimedPose> Drive(double x0, double y0, const std::vector<Leg>& legs,
                                    double dt_s) {
  struct Piece {
    double t0, t1;
    PlacePose a, b;
  };
  std::vector<Piece> pieces;
  PlacePose at{x0, y0, 0, 0};
  double t = 0;
  for (const Leg& l : legs) {
    const double d = std::hypot(l.x_m - at.x_m, l.y_m - at.y_m);
    PlacePose to{l.x_m, l.y_m, 0, std::atan2(l.y_m - at.y_m, l.x_m - at.x_m)};
    at.yaw_rad = to.yaw_rad;
    pieces.push_back({t, t + d / l.speed_mps, at, to});
    t += d / l.speed_mps;
    if (l.stop_s > 0) pieces.push_back({t, t + l.stop_s, to, to});
    t += l.stop_s;
    at = to;
  }
  const double end = t;
  std::vector<TimedPose> out;
  size_t i = 0;
  for (int k = 0;; ++k) {
    double s = k * dt_s;
    if (s > end + 1e-9) {
      if (out.back().t_s < end - 1e-9)
        s = end;  // the end, exactly
      else
        break;
    }
    while (i + 1 < pieces.size() && s > pieces[i].t1 + 1e-12) ++i;
    const Piece& p = pieces[i];
    const double f = p.t1 > p.t0 ? std::clamp((s - p.t0) / (p.t1 - p.t0), 0.0, 1.0) : 1.0;
    PlacePose q = p.a;
    q.x_m += f * (p.b.x_m - p.a.x_m);
    q.y_m += f * (p.b.y_m - p.a.y_m);
    q.yaw_rad = p.b.yaw_rad;
    out.push_back({s, q});
    if (s == end) break;
  }
  return out;
}

// The route of the first reference: 30 m east at 2 m/s, a 3 s stop, 30 m east at 1 m/s,
// 20.5 m north at 1.5 m/s (80.5 m: 81 places 1 m apart, however a corner is cut).
inline std::vector<TimedPose> RouteA(double dt_s) {
  return Drive(0, 0, {{30, 0, 2.0, 3.0}, {60, 0, 1.0, 0}, {60, 20.5, 1.5, 0}}, dt_s);
}
constexpr int kRouteAPlaces = 81;
// The second reference drives part of it at other speeds with a stop: it starts at 10 m,
// stops at 45 m, takes a detour 25 m north and back, rejoins at 55 m, goes on to 60 m, and
// then drives back west to 40 m (a reversed stretch). It never drives the northern leg.
inline std::vector<TimedPose> RouteB(double dt_s) {
  return Drive(10, 0,
               {{45, 0, 3.0, 4.0},
                {45, 25, 2.0, 0},
                {55, 25, 2.0, 0},
                {55, 0, 2.0, 0},
                {60, 0, 1.0, 0},
                {40, 0, 2.5, 0}},
               dt_s);
}
// A query traversal of route A at yet other speeds.
inline std::vector<TimedPose> RouteQ(double dt_s) {
  return Drive(0, 0, {{30, 0, 1.5, 2.0}, {60, 0, 2.5, 0}, {60, 20, 1.0, 0}}, dt_s);
}

// Latitude and longitude of local metres around an origin (the inverse of the core's
// equirectangular LocalMetresFromLatLon, with the same earth radius).
inline void LatLonOf(const PlacePose& p, double lat0, double lon0, double* lat, double* lon) {
  constexpr double kEarthRadiusM = 6371008.8;
  *lat = lat0 + p.y_m / kEarthRadiusM * 180 / kPi;
  *lon = lon0 + p.x_m / (kEarthRadiusM * std::cos(lat0 * kPi / 180)) * 180 / kPi;
}

// The first `count` images of a shipped Nordland 64x32 season, sorted by name.
inline std::vector<std::string> NordlandImages(const std::string& season, size_t count) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(std::string(BSF_SOURCE_DIR) +
                                                           "/data/nordland_64x32/" + season)) {
    files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  if (files.size() > count) files.resize(count);
  return files;
}

// A raw Bayer image of `bgr` in the RobotCar SDK's notation (colour_demosaicing's): the
// four letters of `pattern` are the filters at (0,0), (0,1), (1,0), (1,1) of every 2x2 cell.
inline cv::Mat Mosaic(const cv::Mat& bgr, const std::string& pattern) {
  cv::Mat raw(bgr.size(), CV_8UC1);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) {
      const char filter = pattern[static_cast<size_t>((r % 2) * 2 + (c % 2))];
      const int channel = filter == 'b' ? 0 : filter == 'g' ? 1 : 2;
      raw.at<uchar>(r, c) = bgr.at<cv::Vec3b>(r, c)[channel];
    }
  }
  return raw;
}

constexpr int64_t kEpochUs = 1400000000000000;                // 2014-05-13, as RobotCar's stamps
constexpr double kEasting = 620000.0, kNorthing = 5735000.0;  // UTM zone 30U, Oxford
constexpr double kLat0 = 67.28, kLon0 = 14.40;                // Nordland

// A RobotCar traversal <dir>/<date>/ as the SDK reads it: the drive's frames as
// stereo/centre/<us>.png mosaiced with the stereo camera's pattern 'gbrg', two images before
// the INS log starts, three timestamps of a chunk not downloaded, and gps/ins.csv every
// 0.07 s (so that images fall between INS samples). Returns the folder.
inline std::string WriteRobotCar(const std::string& dir, const std::string& date,
                                 const std::vector<TimedPose>& frames,
                                 const std::vector<TimedPose>& ins, const std::string& season,
                                 int64_t t0_us) {
  const std::string root = dir + "/" + date;
  std::filesystem::create_directories(root + "/stereo/centre");
  std::filesystem::create_directories(root + "/gps");
  const std::vector<std::string> images = NordlandImages(season, frames.size() + 2);
  std::ofstream stamps(root + "/stereo.timestamps");
  std::vector<int64_t> us = {t0_us - 500000, t0_us - 250000};  // before the INS log
  for (const TimedPose& f : frames) us.push_back(t0_us + std::llround(f.t_s * 1e6));
  for (size_t k = 0; k < us.size(); ++k) {
    cv::imwrite(root + "/stereo/centre/" + std::to_string(us[k]) + ".png",
                Mosaic(cv::imread(images[k]), "gbrg"));
    stamps << us[k] << " " << 1 + k / 100 << "\n";
  }
  for (int k = 1; k <= 3; ++k) stamps << us.back() + k * 250000 << " 9\n";  // not downloaded
  std::ofstream csv(root + "/gps/ins.csv");
  csv << "timestamp,ins_status,latitude,longitude,altitude,northing,easting,down,utm_zone,"
         "velocity_north,velocity_east,velocity_down,roll,pitch,yaw\n";
  csv.precision(12);
  for (const TimedPose& s : ins) {
    // The SDK's yaw: from north towards east (NED), so pi/2 - the map frame's heading.
    const double yaw = std::remainder(kPi / 2 - s.pose.yaw_rad, 2 * kPi);
    csv << t0_us + std::llround(s.t_s * 1e6) << ",INS_SOLUTION_GOOD,51.76,-1.26,110,"
        << kNorthing + s.pose.y_m << "," << kEasting + s.pose.x_m << "," << -110 << ",30U,"
        << std::cos(yaw) << "," << std::sin(yaw) << ",0,0.01,-0.02," << yaw << "\n";
  }
  return root;
}

// Nordland frames <dir>/<name>/images-NNNNN.png with frame numbers 100, 101, ... (at 4
// frames per second: --frame-rate-hz 4).
inline std::string WriteNordlandFrames(const std::string& dir, const std::string& name,
                                       size_t count, const std::string& season) {
  const std::string folder = dir + "/" + name;
  std::filesystem::create_directories(folder);
  const std::vector<std::string> images = NordlandImages(season, count);
  for (size_t k = 0; k < count; ++k) {
    char file[32];
    std::snprintf(file, sizeof(file), "images-%05zu.png", 100 + k);
    std::filesystem::copy_file(images[k], folder + "/" + file);
  }
  return folder;
}

// A temporary folder per test, and bsf_import run as a user would.
class ImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/bsf_import_XXXXXX";
    dir_ = mkdtemp(tmpl);
  }
  // BSF_KEEP_TEST_FILES=1 keeps the folder (its path is printed), to look at the fixtures.
  void TearDown() override {
    if (std::getenv("BSF_KEEP_TEST_FILES") != nullptr) {
      std::cerr << "kept " << dir_ << "\n";
    } else {
      std::filesystem::remove_all(dir_);
    }
  }
  Result Run(const std::string& args) const {
    return RunCommand(std::string(BSF_IMPORT_PATH) + " " + args);
  }

  std::string dir_;
};

// What a query bag holds, by topic.
struct BagContents {
  std::vector<std::string> topics;  // of every message, in order
  std::vector<sensor_msgs::Image> images;
  std::vector<Descriptor> descriptors;
  std::vector<geometry_msgs::PoseStamped> poses;
  std::vector<QueryGroundTruth> truths;
};

inline BagContents ReadBag(const std::string& path) {
  BagContents c;
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    c.topics.push_back(m.getTopic());
    if (auto i = m.instantiate<sensor_msgs::Image>()) c.images.push_back(*i);
    if (auto d = m.instantiate<Descriptor>()) c.descriptors.push_back(*d);
    if (auto p = m.instantiate<geometry_msgs::PoseStamped>()) c.poses.push_back(*p);
    if (auto g = m.instantiate<QueryGroundTruth>()) c.truths.push_back(*g);
  }
  return c;
}

inline double YawOf(const geometry_msgs::PoseStamped& p) {
  return 2 * std::atan2(p.pose.orientation.z, p.pose.orientation.w);
}

inline double AngleBetween(double a, double b) { return std::abs(std::remainder(a - b, 2 * kPi)); }

}  // namespace testing
}  // namespace bsf_vpr
