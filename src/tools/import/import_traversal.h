// Traversals as bsf_import reads them from a dataset as downloaded: one drive of the route
// by one camera, its frames in time order with their image (or descriptor row), original
// timestamp and pose. Readers for three layouts (docs/import.md):
//   robotcar  Oxford RobotCar: <traversal>/<camera>/<microseconds>.png raw Bayer images,
//             <camera>.timestamps, gps/ins.csv (read as the RobotCar SDK reads them)
//   nordland  a folder of numbered frames, optionally with a GPS log (latitude, longitude)
//   generic   an image folder or a descriptor .npy, with a CSV of one pose per image or row
// Nothing here writes files. Errors are std::runtime_error naming the file (and line).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {
namespace tools {

enum class DatasetFolders { kRobotCar, kNordland, kGeneric };
// The layouts' names (--layout).
const EnumNames<DatasetFolders>& DatasetFoldersNames();
// A name of DatasetFoldersNames(); throws std::invalid_argument naming the choices.
DatasetFolders ParseDatasetFolders(const std::string& text);
std::string ToString(DatasetFolders layout);

// The coordinates a traversal's logged poses are given in, before BringToMapFrame. (Not the
// fusion node's PoseSource, which says where the robot's live pose comes from: tf or a
// topic.)
enum class PoseCoordinates {
  kNone,      // no poses: frame-aligned (Nordland without GPS), frame k is place k
  kMapFrame,  // metres and radians in the map frame as given (generic x,y,z,yaw)
  kUtm,       // RobotCar INS: x easting, y northing, z up (metres), yaw as in the map frame
  kLatLon,    // latitude/longitude fixes (Frame::fix); no heading
};
// What each kind of coordinates gives, for messages ("UTM poses").
const EnumNames<PoseCoordinates>& PoseCoordinatesNames();
std::string ToString(PoseCoordinates coordinates);

struct GeoFix {
  double latitude_deg = 0, longitude_deg = 0;
};

struct Frame {
  std::string image;     // image file; empty for a descriptor row
  int row = -1;          // row of Traversal::descriptors (a descriptor .npy)
  int64_t stamp_ns = 0;  // original time, > 0 (see each layout)
  PlacePose pose;        // kMapFrame / kUtm (after BringToMapFrame: the map frame for all)
  GeoFix fix;            // kLatLon, until BringToMapFrame
};

struct Traversal {
  std::string name;
  PoseCoordinates pose_coordinates = PoseCoordinates::kNone;
  std::vector<Frame> frames;  // time order; frames without a pose are left out (counted)
  RowMatrixXf descriptors;    // a descriptor .npy (generic); empty for images
  std::string image_folder;   // the folder holding the frames' images; "" for a .npy
  // The first sample of the pose log (RobotCar: ins.csv, Nordland: the GPS log), in the
  // log's own coordinates: the origin of the map frame when this is the first reference.
  PlacePose first_utm;
  GeoFix first_fix;
  // OpenCV's cv::COLOR_Bayer*2BGR code that demosaics the images; -1 when they are colour.
  int bayer_code = -1;
  int without_pose = 0;    // frames left out: no pose at their time
  int not_downloaded = 0;  // RobotCar: timestamps without an image (chunk not downloaded)
};

struct ReadOptions {
  std::string camera = "stereo/centre";  // RobotCar: the camera's folder in the traversal
  double frame_rate_hz = 1;              // Nordland: frame number n was taken at n / this
};

// Reads traversal `name` from `spec` (see docs/import.md for each layout's spec).
Traversal ReadTraversal(DatasetFolders layout, const std::string& name, const std::string& spec,
                        const ReadOptions& options);

// The layouts (ReadTraversal calls one of these):
// RobotCar: `folder` is one traversal (<date>/); images <folder>/<camera>/<us>.png listed
// by the camera's .timestamps ('<us> <chunk>' per line; found beside the camera's folder
// or one level up, as the SDK's play_images.py looks), poses from <folder>/gps/ins.csv
// interpolated at each image's stamp. Stamps: the microseconds of the names.
Traversal ReadRobotCarTraversal(const std::string& name, const std::string& folder,
                                const std::string& camera);
// Nordland: frames <folder>/*N.png|jpg with frame number N (the last digits of the name,
// increasing with the name); stamps 1000 s + N / frame_rate_hz. With `gps_csv` (columns
// frame or timestamp, latitude, longitude) the fixes are interpolated at each frame.
Traversal ReadNordlandTraversal(const std::string& name, const std::string& folder,
                                const std::string& gps_csv, double frame_rate_hz);
// Generic: `source` is an image folder (images sorted by name) or a descriptor .npy; the
// CSV has one row per image or .npy row: timestamp,x,y,z,yaw or timestamp,lat,lon.
Traversal ReadGenericTraversal(const std::string& name, const std::string& source,
                               const std::string& poses_csv);

// Puts every traversal's poses into one map frame: x east, y north, z up (metres), yaw
// counter-clockwise from east (radians). UTM positions and latitude/longitude fixes are
// taken relative to the first sample of `traversals[0]`'s log (the first reference);
// latitude/longitude become local metres (LocalMetresFromLatLon) with headings from the
// path (HeadingsFromPath). Throws std::runtime_error when the traversals' pose coordinates
// differ, naming the traversal. Returns the origin as text for the user ("" for none).
std::string BringToMapFrame(std::vector<Traversal>* traversals);

// The demosaicing code of a RobotCar camera (the SDK's image.py: 'gbrg' for the stereo
// camera, 'rggb' for the mono ones). Throws std::invalid_argument for another camera.
int RobotCarBayerCode(const std::string& camera);

// The frame's image as 8-bit BGR: decoded, demosaiced with traversal.bayer_code when raw,
// and resized to `size` (area interpolation) unless it is empty. Throws
// std::runtime_error naming the file when it cannot be decoded or is not raw Bayer when it
// should be.
cv::Mat LoadFrameImage(const Traversal& traversal, const Frame& frame, cv::Size size);

}  // namespace tools
}  // namespace bsf_vpr
