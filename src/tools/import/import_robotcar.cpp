// The Oxford RobotCar layout, as the RobotCar SDK (github.com/ori-mrg/robotcar-dataset-sdk)
// reads it:
//   python/play_images.py   <camera>.timestamps beside the image folder's parent or one
//                           level further up; '<microseconds> <chunk>' per line; an image
//                           <microseconds>.png that is missing belongs to a chunk not
//                           downloaded and is passed over
//   python/image.py         raw Bayer images, pattern 'gbrg' for the stereo camera and
//                           'rggb' for the mono cameras (colour_demosaicing's naming: the
//                           four letters are the filters at (0,0), (0,1), (1,0), (1,1))
//   python/interpolate_poses.py  gps/ins.csv with a header; timestamp (microseconds),
//                           northing, easting, down (metres) and roll, pitch, yaw (radians)
//                           as the last three columns
//   python/transform.py     those Euler angles rotate (north, east, down): R_z(yaw) R_y R_x.
//                           So yaw turns north towards east, clockwise seen from above: 0
//                           is north, pi/2 east. In the map frame (x east, y north, yaw
//                           counter-clockwise from east, REP 103) the heading is pi/2 - yaw.
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "bsf_vpr/core/place_index.h"
#include "src/tools/import/import_csv.h"
#include "src/tools/import/import_traversal.h"

namespace bsf_vpr {
namespace tools {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
// A frame between two INS samples further apart than this has no pose (an INS outage).
constexpr double kMaxPoseGapS = 2.0;

// "stereo" or "mono_left|right|rear": the camera's name in the SDK (its .timestamps file).
std::string CameraName(const std::string& camera) {
  std::smatch m;
  if (!std::regex_search(camera, m, std::regex("(stereo|mono_(left|right|rear))"))) {
    throw std::invalid_argument(
        "--camera must name a RobotCar camera folder (stereo/centre, stereo/left, "
        "stereo/right, mono_left, mono_right or mono_rear), got '" +
        camera + "'");
  }
  return m.str(0);
}

// '<microseconds> <chunk>' lines, in order.
std::vector<int64_t> ReadTimestamps(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read '" + path.string() + "'");
  std::vector<int64_t> stamps;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    std::istringstream ss(line);
    long long us = 0, chunk = 0;
    std::string rest;
    if (!(ss >> us)) {
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;  // blank line
    }
    if (!ss || !(ss >> chunk) || (ss >> rest) || us <= 0) {
      throw std::runtime_error("'" + path.string() + "' line " + std::to_string(line_no) +
                               ": expected '<microseconds> <chunk>', got '" + line + "'");
    }
    if (!stamps.empty() && us <= stamps.back()) {
      throw std::runtime_error("'" + path.string() + "' line " + std::to_string(line_no) +
                               ": timestamps must increase");
    }
    stamps.push_back(us);
  }
  if (stamps.empty()) throw std::runtime_error("'" + path.string() + "' lists no image");
  return stamps;
}

// gps/ins.csv as a track in seconds, positions in UTM metres (x easting, y northing, z up)
// and yaw in the map frame's convention.
PoseTrack ReadIns(const std::string& path) {
  const CsvTable t = CsvTable::Read(path);
  const int ts = t.Require({"timestamp"}), north = t.Require({"northing"}),
            east = t.Require({"easting"}), down = t.Require({"down"}), yaw = t.Require({"yaw"});
  if (t.rows() == 0) throw std::runtime_error("'" + path + "' has no samples");
  PoseTrack track;
  int64_t last_us = 0;
  for (size_t r = 0; r < t.rows(); ++r) {
    const int64_t us = t.Integer(r, ts);
    if (r > 0 && us <= last_us) throw std::runtime_error(t.Where(r) + ": timestamps must increase");
    last_us = us;
    track.stamps_s.push_back(static_cast<double>(us) * 1e-6);
    track.poses.push_back(PlacePose{t.Number(r, east), t.Number(r, north), -t.Number(r, down),
                                    std::remainder(kPi / 2 - t.Number(r, yaw), 2 * kPi)});
  }
  return track;
}

// The folder path without a trailing separator ("a/b/" -> "a/b").
fs::path Folder(const fs::path& p) {
  const fs::path n = p.lexically_normal();
  return n.has_filename() ? n : n.parent_path();
}

}  // namespace

int RobotCarBayerCode(const std::string& camera) {
  // OpenCV names a pattern by the second row's second and third pixels: the SDK's 'gbrg'
  // (G B / R G) is cv::COLOR_BayerGR2BGR, its 'rggb' (R G / G B) cv::COLOR_BayerBG2BGR.
  // test_import.cpp mosaics known colours with the SDK's patterns and checks this.
  return CameraName(camera) == "stereo" ? cv::COLOR_BayerGR2BGR : cv::COLOR_BayerBG2BGR;
}

Traversal ReadRobotCarTraversal(const std::string& name, const std::string& folder,
                                const std::string& camera) {
  Traversal t;
  t.name = name;
  t.pose_coordinates = PoseCoordinates::kUtm;
  t.bayer_code = RobotCarBayerCode(camera);
  const fs::path images = Folder(fs::path(folder) / camera);
  if (!fs::is_directory(images)) {
    throw std::runtime_error("no camera folder '" + images.string() + "' (see --camera)");
  }
  const std::string file = CameraName(camera) + ".timestamps";
  fs::path stamps_path = images.parent_path() / file;
  if (!fs::is_regular_file(stamps_path)) {
    const fs::path up = images.parent_path().parent_path() / file;
    if (!fs::is_regular_file(up)) {
      throw std::runtime_error("no '" + stamps_path.string() + "' or '" + up.string() + "'");
    }
    stamps_path = up;
  }
  t.image_folder = images.string();
  const std::vector<int64_t> stamps = ReadTimestamps(stamps_path);
  const PoseTrack ins = ReadIns((fs::path(folder) / "gps" / "ins.csv").string());
  t.first_utm = ins.poses.front();
  for (const int64_t us : stamps) {
    const fs::path image = images / (std::to_string(us) + ".png");
    if (!fs::exists(image)) {
      ++t.not_downloaded;
      continue;
    }
    const std::optional<PlacePose> pose =
        InterpolatePose(ins, static_cast<double>(us) * 1e-6, kMaxPoseGapS);
    if (!pose) {
      ++t.without_pose;
      continue;
    }
    Frame f;
    f.image = image.string();
    f.stamp_ns = us * 1000;
    f.pose = *pose;
    t.frames.push_back(std::move(f));
  }
  return t;
}

}  // namespace tools
}  // namespace bsf_vpr
