// bsf_make_bag: turns an image folder or a descriptor .npy (plus optional ground truth and
// query poses) into a bag that replays a traversal (see --help).
#include <cmath>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "bsf_vpr/evaluation/evaluation.h"
#include "bsf_vpr/evaluation/ground_truth_io.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "src/tools/common/cli_util.h"
#include "src/tools/common/query_bag.h"

namespace {

const char kUsage[] =
    R"(usage: bsf_make_bag (--images DIR | --descriptors PATH.npy) --out BAG [options]

Writes one message per query at a fixed rate, so that a traversal can be replayed with
`rosbag play --clock` (or launch/replay.launch):
  --images DIR           images (sorted by name) as sensor_msgs/Image (bgr8) on --topic
                         (default /camera/image_raw)
  --descriptors PATH     rows of a Q x D .npy as bsf_vpr/Descriptor on --topic
                         (default /vpr/descriptor)
  --out BAG              the bag to write: written as BAG.tmp, then renamed to BAG (removed
                         on failure); missing folders are created
  --rate HZ              messages per second (default 10)
  --ground-truth CSV     correct places per query ('query,place place ...'), written as
                         bsf_vpr/QueryGroundTruth on /vpr/ground_truth with each query's stamp
  --tolerance K          instead: query q is correct at places q-K .. q+K (frame-aligned)
  --num-places N         with --tolerance: size of the place index (default: Q)
  --poses CSV            query poses 'query,x,y,z,yaw' (metres, radians), written as
                         geometry_msgs/PoseStamped on /vpr/query_pose in --frame
  --frame NAME           frame of the query poses (default map)
  --topic NAME           topic of the images or descriptors
  --limit N              only the first N queries
  -h, --help             this help
Exit status 2 with one line naming the problem on bad arguments or input.
)";

constexpr double kStartTime = 1000.0;  // seconds: a fixed, non-zero stamp of the first query

struct Args {
  std::string images, descriptors, out, ground_truth, poses, topic, frame = "map";
  double rate_hz = 10;
  int tolerance = -1, num_places = 0, limit = 0;
};

Args Parse(int argc, char** argv, bool* help) {
  Args a;
  bsf_vpr::tools::FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--images")
      a.images = v;
    else if (f == "--descriptors")
      a.descriptors = v;
    else if (f == "--out")
      a.out = v;
    else if (f == "--rate")
      a.rate_hz = bsf_vpr::tools::ParseNumber(f, v);
    else if (f == "--ground-truth")
      a.ground_truth = v;
    else if (f == "--tolerance")
      a.tolerance = bsf_vpr::tools::ParseInteger(f, v);
    else if (f == "--num-places")
      a.num_places = bsf_vpr::tools::ParseInteger(f, v);
    else if (f == "--poses")
      a.poses = v;
    else if (f == "--topic")
      a.topic = v;
    else if (f == "--frame")
      a.frame = v;
    else if (f == "--limit")
      a.limit = bsf_vpr::tools::ParseInteger(f, v);
    else
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
  }
  if (flags.help()) {
    *help = true;
    return a;
  }
  if (a.images.empty() == a.descriptors.empty()) {
    throw std::invalid_argument("give exactly one of --images DIR and --descriptors PATH.npy");
  }
  if (a.out.empty()) throw std::invalid_argument("no --out BAG given");
  if (!(a.rate_hz > 0)) throw std::invalid_argument("--rate must be > 0");
  if (!a.ground_truth.empty() && a.tolerance >= 0) {
    throw std::invalid_argument("give at most one of --ground-truth and --tolerance");
  }
  if (a.limit < 0 || a.num_places < 0)
    throw std::invalid_argument("--limit and --num-places must be >= 0");
  if (a.topic.empty())
    a.topic =
        a.images.empty() ? bsf_vpr::tools::kQueryDescriptorTopic : bsf_vpr::tools::kQueryImageTopic;
  return a;
}

// 'query,x,y,z,yaw' rows; returns poses indexed by query (missing rows: none).
std::vector<std::optional<bsf_vpr::PlacePose>> ReadPoses(const std::string& path, int queries) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read poses '" + path + "'");
  std::vector<std::optional<bsf_vpr::PlacePose>> poses(static_cast<size_t>(queries));
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    if (line.empty() || (line_no == 1 && line.rfind("query", 0) == 0)) continue;
    std::stringstream ss(line);
    std::string cell;
    std::vector<double> v;
    while (std::getline(ss, cell, ','))
      v.push_back(bsf_vpr::tools::ParseNumber(
          "poses '" + path + "' line " + std::to_string(line_no), cell));
    if (v.size() != 5 || v[0] < 0 || v[0] >= queries || v[0] != std::floor(v[0])) {
      throw std::runtime_error("poses '" + path + "' line " + std::to_string(line_no) +
                               ": expected 'query,x,y,z,yaw' with a query in 0.." +
                               std::to_string(queries - 1));
    }
    poses[static_cast<size_t>(v[0])] = bsf_vpr::PlacePose{v[1], v[2], v[3], v[4]};
  }
  return poses;
}

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  bool help = false;
  const Args a = Parse(argc, argv, &help);
  if (help) {
    std::cout << kUsage;
    return 0;
  }
  std::vector<std::string> files;
  RowMatrixXf descriptors;
  if (!a.images.empty()) {
    files = ListImageFiles(a.images);
  } else {
    descriptors = ReadNpyMatrix(a.descriptors);
    if (!descriptors.allFinite())
      throw std::invalid_argument("'" + a.descriptors + "' holds NaN or infinity");
  }
  int q = static_cast<int>(a.images.empty() ? descriptors.rows()
                                            : static_cast<Eigen::Index>(files.size()));
  if (a.limit > 0) q = std::min(q, a.limit);
  std::optional<GroundTruth> truth;
  if (!a.ground_truth.empty())
    truth = ReadGroundTruthCsv(a.ground_truth, q, a.num_places > 0 ? a.num_places : 1 << 30);
  if (a.tolerance >= 0)
    truth = GroundTruth::FromFrameTolerance(q, a.num_places > 0 ? a.num_places : q, a.tolerance);
  const auto poses =
      a.poses.empty() ? std::vector<std::optional<PlacePose>>() : ReadPoses(a.poses, q);

  tools::QueryBagWriter bag(a.out, a.topic, a.frame);
  for (int k = 0; k < q; ++k) {
    const ros::Time stamp(kStartTime + k / a.rate_hz);
    if (!a.images.empty()) {
      const cv::Mat img = cv::imread(files[static_cast<size_t>(k)], cv::IMREAD_COLOR);
      if (img.empty())
        throw std::runtime_error("cannot decode image '" + files[static_cast<size_t>(k)] + "'");
      bag.WriteImage(stamp, img);
    } else {
      bag.WriteDescriptor(stamp, descriptors.row(k).data(), static_cast<int>(descriptors.cols()));
    }
    if (truth) bag.WriteGroundTruth(stamp, k, truth->CorrectPlaces(k));
    if (!poses.empty() && poses[static_cast<size_t>(k)])
      bag.WritePose(stamp, *poses[static_cast<size_t>(k)]);
  }
  bag.Commit();
  std::cout << "bsf_make_bag: wrote " << q << " queries at " << a.rate_hz << " Hz to " << a.out
            << " (" << a.topic << (truth ? std::string(", ") + tools::kGroundTruthTopic : "")
            << (poses.empty() ? "" : std::string(", ") + tools::kQueryPoseTopic) << ")\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return bsf_vpr::tools::RunTool("bsf_make_bag", Run, argc, argv); }
