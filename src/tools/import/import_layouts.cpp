// The Nordland and generic layouts, the map frame all traversals share, and frame images.
#include <cctype>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "src/tools/import/import_csv.h"
#include "src/tools/import/import_traversal.h"

namespace bsf_vpr {
namespace tools {
namespace {

namespace fs = std::filesystem;
// Relative times (Nordland frame numbers) start here: ROS time 0 means "no time".
constexpr int64_t kStartTimeNs = 1000'000'000'000;
// A frame between two GPS fixes further apart than this has no pose (a GPS outage).
constexpr double kMaxPoseGapS = 2.0;

int64_t SecondsToNs(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }

// "A,B" -> {A, B}; "A" -> {A}. Throws when there are more parts than `max_parts`.
std::vector<std::string> SplitSpec(const std::string& spec, size_t max_parts,
                                   const std::string& form) {
  std::vector<std::string> parts;
  std::stringstream ss(spec);
  for (std::string p; std::getline(ss, p, ',');) parts.push_back(p);
  if (parts.empty() || parts.size() > max_parts) {
    throw std::invalid_argument("expected " + form + ", got '" + spec + "'");
  }
  for (const std::string& p : parts) {
    if (p.empty()) throw std::invalid_argument("expected " + form + ", got '" + spec + "'");
  }
  return parts;
}

// The last run of digits in a file name's stem ("images-00010.png" -> 10), or -1.
int64_t FrameNumber(const std::string& file) {
  const std::string stem = fs::path(file).stem().string();
  const size_t end = stem.find_last_of("0123456789");
  if (end == std::string::npos) return -1;
  size_t begin = end;
  while (begin > 0 && std::isdigit(static_cast<unsigned char>(stem[begin - 1]))) --begin;
  if (end + 1 - begin > 15) return -1;  // no frame number has 16 digits
  return std::stoll(stem.substr(begin, end + 1 - begin));
}

}  // namespace

const EnumNames<DatasetFolders>& DatasetFoldersNames() {
  static const EnumNames<DatasetFolders> kNames{{DatasetFolders::kRobotCar, "robotcar"},
                                               {DatasetFolders::kNordland, "nordland"},
                                               {DatasetFolders::kGeneric, "generic"}};
  return kNames;
}

DatasetFolders ParseDatasetFolders(const std::string& text) {
  // The choices as the usage text shows them, not EnumNames::Parse's "a, b or c".
  const std::optional<DatasetFolders> layout = DatasetFoldersNames().Find(text);
  if (!layout) {
    throw std::invalid_argument("--layout must be " + DatasetFoldersNames().Listed(" | ", " | ") +
                                ", got '" + text + "'");
  }
  return *layout;
}

std::string ToString(DatasetFolders layout) { return DatasetFoldersNames().Name(layout); }

const EnumNames<PoseCoordinates>& PoseCoordinatesNames() {
  static const EnumNames<PoseCoordinates> kNames{
      {PoseCoordinates::kNone, "no poses (frame-aligned)"},
      {PoseCoordinates::kMapFrame, "x,y,z,yaw poses"},
      {PoseCoordinates::kUtm, "UTM poses"},
      {PoseCoordinates::kLatLon, "latitude/longitude fixes"}};
  return kNames;
}

std::string ToString(PoseCoordinates coordinates) {
  return PoseCoordinatesNames().Name(coordinates);
}

Traversal ReadTraversal(DatasetFolders layout, const std::string& name, const std::string& spec,
                        const ReadOptions& options) {
  switch (layout) {
    case DatasetFolders::kRobotCar:
      return ReadRobotCarTraversal(name, spec, options.camera);
    case DatasetFolders::kNordland: {
      const auto parts = SplitSpec(spec, 2, "FRAMES_DIR or FRAMES_DIR,GPS_CSV");
      return ReadNordlandTraversal(name, parts[0], parts.size() > 1 ? parts[1] : "",
                                   options.frame_rate_hz);
    }
    case DatasetFolders::kGeneric: {
      const auto parts = SplitSpec(spec, 2, "IMAGE_DIR,POSES_CSV or DESCRIPTORS.npy,POSES_CSV");
      if (parts.size() != 2) {
        throw std::invalid_argument(
            "expected IMAGE_DIR,POSES_CSV or DESCRIPTORS.npy,POSES_CSV, got '" + spec + "'");
      }
      return ReadGenericTraversal(name, parts[0], parts[1]);
    }
  }
  throw std::logic_error("unknown layout");
}

Traversal ReadNordlandTraversal(const std::string& name, const std::string& folder,
                                const std::string& gps_csv, double frame_rate_hz) {
  Traversal t;
  t.name = name;
  t.image_folder = folder;
  const std::vector<std::string> files = ListImageFiles(folder);
  std::vector<double> times_s;  // of each file
  for (size_t k = 0; k < files.size(); ++k) {
    const int64_t n = FrameNumber(files[k]);
    if (n < 0) throw std::runtime_error("'" + files[k] + "': no frame number in the name");
    times_s.push_back(static_cast<double>(n) / frame_rate_hz);
    if (k > 0 && !(times_s[k] > times_s[k - 1])) {
      throw std::runtime_error("'" + files[k] + "': frame numbers must increase with the names (" +
                               "it follows '" + files[k - 1] + "')");
    }
  }
  if (gps_csv.empty()) {
    for (size_t k = 0; k < files.size(); ++k) {
      Frame f;
      f.image = files[k];
      f.stamp_ns = kStartTimeNs + SecondsToNs(times_s[k]);
      t.frames.push_back(std::move(f));
    }
    return t;
  }
  t.pose_coordinates = PoseCoordinates::kLatLon;
  const CsvTable csv = CsvTable::Read(gps_csv);
  const int frame_col = csv.Find({"frame"});
  const int time_col = frame_col >= 0 ? -1 : csv.Require({"frame", "timestamp"});
  const int lat = csv.Require({"latitude", "lat"}), lon = csv.Require({"longitude", "lon"});
  if (csv.rows() == 0) throw std::runtime_error("'" + gps_csv + "' has no fixes");
  // The fixes as a track in seconds (x longitude, y latitude: interpolating degrees is
  // interpolating local metres, which are affine in them).
  PoseTrack track;
  for (size_t r = 0; r < csv.rows(); ++r) {
    const double s = frame_col >= 0 ? static_cast<double>(csv.Integer(r, frame_col)) / frame_rate_hz
                                    : csv.Number(r, time_col);
    if (r > 0 && !(s > track.stamps_s.back())) {
      throw std::runtime_error(csv.Where(r) + ": frames or timestamps must increase");
    }
    const double la = csv.Number(r, lat), lo = csv.Number(r, lon);
    if (std::abs(la) > 90 || std::abs(lo) > 180) {
      throw std::runtime_error(csv.Where(r) + ": latitude/longitude out of range");
    }
    track.stamps_s.push_back(s);
    track.poses.push_back(PlacePose{lo, la, 0, 0});
  }
  t.first_fix = GeoFix{track.poses[0].y_m, track.poses[0].x_m};
  for (size_t k = 0; k < files.size(); ++k) {
    const std::optional<PlacePose> p = InterpolatePose(track, times_s[k], kMaxPoseGapS);
    if (!p) {
      ++t.without_pose;
      continue;
    }
    Frame f;
    f.image = files[k];
    f.stamp_ns = kStartTimeNs + SecondsToNs(times_s[k]);
    f.fix = GeoFix{p->y_m, p->x_m};
    t.frames.push_back(std::move(f));
  }
  return t;
}

Traversal ReadGenericTraversal(const std::string& name, const std::string& source,
                               const std::string& poses_csv) {
  Traversal t;
  t.name = name;
  std::vector<std::string> files;
  size_t count = 0;
  if (fs::path(source).extension() == ".npy") {
    t.descriptors = ReadNpyMatrix(source);
    if (!t.descriptors.allFinite())
      throw std::runtime_error("'" + source + "' holds NaN or infinity");
    count = static_cast<size_t>(t.descriptors.rows());
  } else {
    files = ListImageFiles(source);
    count = files.size();
    t.image_folder = source;
  }
  const CsvTable csv = CsvTable::Read(poses_csv);
  const int ts = csv.Require({"timestamp"});
  const int x = csv.Find({"x"});
  int y = -1, z = -1, yaw = -1, lat = -1, lon = -1;
  if (x >= 0) {
    t.pose_coordinates = PoseCoordinates::kMapFrame;
    y = csv.Require({"y"}), z = csv.Require({"z"}), yaw = csv.Require({"yaw"});
  } else if (csv.Find({"lat", "latitude"}) >= 0) {
    t.pose_coordinates = PoseCoordinates::kLatLon;
    lat = csv.Require({"lat", "latitude"}), lon = csv.Require({"lon", "longitude"});
  } else {
    throw std::runtime_error("'" + poses_csv +
                             "' line 1: expected the columns timestamp,x,y,z,yaw or "
                             "timestamp,lat,lon");
  }
  if (csv.rows() != count) {
    throw std::runtime_error("'" + poses_csv + "' has " + std::to_string(csv.rows()) + " rows, '" +
                             source + "' " + std::to_string(count) +
                             (files.empty() ? " descriptor rows" : " images") +
                             ": one pose per image or row");
  }
  for (size_t r = 0; r < count; ++r) {
    Frame f;
    if (files.empty()) {
      f.row = static_cast<int>(r);
    } else {
      f.image = files[r];
    }
    f.stamp_ns = SecondsToNs(csv.Number(r, ts));
    if (f.stamp_ns <= 0) {
      throw std::runtime_error(csv.Where(r) +
                               ": timestamps must be > 0 s (ROS time 0 means no time)");
    }
    if (r > 0 && f.stamp_ns < t.frames.back().stamp_ns) {
      throw std::runtime_error(csv.Where(r) + ": timestamps must not decrease");
    }
    if (t.pose_coordinates == PoseCoordinates::kMapFrame) {
      f.pose = PlacePose{csv.Number(r, x), csv.Number(r, y), csv.Number(r, z), csv.Number(r, yaw)};
    } else {
      f.fix = GeoFix{csv.Number(r, lat), csv.Number(r, lon)};
      if (std::abs(f.fix.latitude_deg) > 90 || std::abs(f.fix.longitude_deg) > 180) {
        throw std::runtime_error(csv.Where(r) + ": latitude/longitude out of range");
      }
    }
    t.frames.push_back(std::move(f));
  }
  if (!t.frames.empty()) t.first_fix = t.frames.front().fix;
  return t;
}

std::string BringToMapFrame(std::vector<Traversal>* traversals) {
  std::vector<Traversal>& all = *traversals;
  if (all.empty()) return "";
  const Traversal& first = all.front();
  for (const Traversal& t : all) {
    if (t.pose_coordinates != first.pose_coordinates) {
      throw std::runtime_error("traversal '" + t.name + "' has " + ToString(t.pose_coordinates) +
                               ", the first reference '" + first.name + "' " +
                               ToString(first.pose_coordinates) + ": one import, one kind of pose");
    }
  }
  std::ostringstream origin;
  origin.precision(12);
  if (first.pose_coordinates == PoseCoordinates::kUtm) {
    const PlacePose o = first.first_utm;
    for (Traversal& t : all) {
      for (Frame& f : t.frames) {
        f.pose.x_m -= o.x_m;
        f.pose.y_m -= o.y_m;
        f.pose.z_m -= o.z_m;
      }
    }
    origin << "UTM easting " << o.x_m << " m, northing " << o.y_m << " m, up " << o.z_m
           << " m (the first sample of '" << first.name << "'s gps/ins.csv)";
  } else if (first.pose_coordinates == PoseCoordinates::kLatLon) {
    const GeoFix o = first.first_fix;
    for (Traversal& t : all) {
      std::vector<PlacePose> poses;
      for (const Frame& f : t.frames) {
        poses.push_back(LocalMetresFromLatLon(f.fix.latitude_deg, f.fix.longitude_deg,
                                              o.latitude_deg, o.longitude_deg));
      }
      HeadingsFromPath(&poses);
      for (size_t k = 0; k < poses.size(); ++k) t.frames[k].pose = poses[k];
    }
    origin << "latitude " << o.latitude_deg << ", longitude " << o.longitude_deg
           << " (the first fix of '" << first.name << "')";
  }
  return origin.str();
}

cv::Mat LoadFrameImage(const Traversal& traversal, const Frame& frame, cv::Size size) {
  cv::Mat image;
  if (traversal.bayer_code >= 0) {
    const cv::Mat raw = cv::imread(frame.image, cv::IMREAD_UNCHANGED);
    if (raw.empty()) throw std::runtime_error("cannot decode image '" + frame.image + "'");
    if (raw.type() != CV_8UC1) {
      throw std::runtime_error("'" + frame.image +
                               "' is not a raw Bayer image (8-bit, one channel) as the "
                               "RobotCar dataset distributes them: it has " +
                               std::to_string(raw.channels()) + " channels of " +
                               std::to_string(raw.elemSize1() * 8) + " bits");
    }
    cv::cvtColor(raw, image, traversal.bayer_code);
  } else {
    image = cv::imread(frame.image, cv::IMREAD_COLOR);
    if (image.empty()) throw std::runtime_error("cannot decode image '" + frame.image + "'");
  }
  if (!size.empty() && image.size() != size) {
    cv::Mat resized;
    cv::resize(image, resized, size, 0, 0, cv::INTER_AREA);
    return resized;
  }
  return image;
}

}  // namespace tools
}  // namespace bsf_vpr
