#include "src/tools/import/import_args.h"

#include <algorithm>
#include <cmath>
#include <regex>
#include <set>
#include <stdexcept>

#include "bsf_vpr/core/distances.h"
#include "src/tools/common/cli_util.h"
#include "src/tools/common/describer_flags.h"

namespace bsf_vpr {
namespace tools {
namespace {

constexpr int kMaxImageSidePx = 1 << 14;

NamedSpec ParseNamedSpec(const std::string& flag, const std::string& value) {
  const size_t eq = value.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == value.size()) {
    throw std::invalid_argument(flag + " expects NAME=SPEC, got '" + value + "'");
  }
  NamedSpec s{value.substr(0, eq), value.substr(eq + 1)};
  // The name becomes a file name (NAME.yaml, NAME.bag) and a set name (nn:NAME).
  if (!std::regex_match(s.name, std::regex("[A-Za-z0-9_][A-Za-z0-9_.-]*"))) {
    throw std::invalid_argument(flag + ": NAME may hold letters, digits, '_', '-' and '.' (not " +
                                "first), got '" + s.name + "'");
  }
  return s;
}

cv::Size ParseSize(const std::string& flag, const std::string& value) {
  std::smatch m;
  if (!std::regex_match(value, m, std::regex("([0-9]{1,9})x([0-9]{1,9})"))) {
    throw std::invalid_argument(flag + " expects WxH in pixels (e.g. 640x480), got '" + value +
                                "'");
  }
  const long long w = std::stoll(m[1]), h = std::stoll(m[2]);
  if (w < 1 || h < 1 || w > kMaxImageSidePx || h > kMaxImageSidePx) {
    throw std::invalid_argument(flag + ": width and height must lie in 1.." +
                                std::to_string(kMaxImageSidePx) + ", got '" + value + "'");
  }
  return cv::Size(static_cast<int>(w), static_cast<int>(h));
}

void CheckNames(const std::vector<NamedSpec>& specs, const char* flag) {
  std::set<std::string> seen;
  for (const NamedSpec& s : specs) {
    if (!seen.insert(s.name).second) {
      throw std::invalid_argument(std::string(flag) + ": the name '" + s.name + "' is given twice");
    }
  }
}

void CheckCombination(const ImportArgs& a) {
  if (a.references.empty()) throw std::invalid_argument("give at least one --reference NAME=SPEC");
  if (a.out_dir.empty()) throw std::invalid_argument("no --out DIR given");
  CheckNames(a.references, "--reference");
  CheckNames(a.queries, "--query");
  for (const auto& [name, condition] : a.conditions) {
    if (std::none_of(a.references.begin(), a.references.end(),
                     [&wanted = name](const NamedSpec& s) { return s.name == wanted; })) {
      throw std::invalid_argument("--condition " + name + "=" + condition +
                                  ": there is no --reference named '" + name + "'");
    }
  }
  if (a.Given("camera") && a.layout != DatasetFolders::kRobotCar) {
    throw std::invalid_argument("--camera goes with --layout robotcar");
  }
  if (a.Given("frame_rate_hz") && a.layout != DatasetFolders::kNordland) {
    throw std::invalid_argument("--frame-rate-hz goes with --layout nordland");
  }
  a.options.place_index.Validate();
}

}  // namespace

const OptionTable<ImportOptions>& ImportOptionsTable() {
  static const OptionTable<ImportOptions> kTable =
      OptionTable<ImportOptions>()
          .Add(
              "camera", [](auto& o) -> auto& { return o.camera; },
              "robotcar: the camera folder in each traversal (stereo/centre, stereo/left, "
              "stereo/right, mono_left, mono_right, mono_rear)")
          .Add(
              "frame_rate_hz", [](auto& o) -> auto& { return o.frame_rate_hz; },
              "nordland: frame number N was taken at N / this (1: the frames as distributed, "
              "one per second of video)",
              "Hz", Above(0))
          .Include(
              PlaceIndexOptionsTable(), [](auto& o) -> auto& { return o.place_index; })
          .Add(
              "tolerance_m", [](auto& o) -> auto& { return o.tolerance_m; },
              "query ground truth: the places within this planar distance of the query's pose", "m",
              AtLeast(0))
          .Add(
              "tolerance", [](auto& o) -> auto& { return o.tolerance; },
              "query ground truth without poses (frame-aligned): query k is correct at places "
              "k-N..k+N",
              "places", AtLeast(0))
          .Add(
              "rate_hz", [](auto& o) -> auto& { return o.rate_hz; },
              "query k at 1000 s + k / this instead of its original timestamp (0: original)", "Hz",
              AtLeast(0))
          .Add(
              "query_descriptors", [](auto& o) -> auto& { return o.query_descriptors; },
              "queries as bsf_vpr/Descriptor on /vpr/descriptor (described as the references) "
              "instead of images; always so for a descriptor .npy");
  return kTable;
}

bool ImportArgs::Given(const std::string& option_name) const {
  return std::find(flags_given.begin(), flags_given.end(), option_name) != flags_given.end();
}

std::string ImportUsage() {
  return R"(usage: bsf_import --layout robotcar|nordland|generic --reference NAME=SPEC [...]
                  [--query NAME=SPEC ...] --out DIR [options]

Imports a dataset as downloaded: every --reference traversal becomes the reference set
DIR/NAME.yaml (+ its .npy), all on ONE place index, and every --query traversal the bag
DIR/NAME.bag for launch/replay.launch and bsf_evaluate. The first reference makes the
places (one every --place-spacing-m along its route); each further reference covers the
places it passes (within --association-radius-m and --max-yaw-difference-deg); places it
does not pass stay uncovered. Without poses (nordland without GPS) frame k is place k.
A set made from images names each row's frame (the YAML's images: and image_files:).
Workflow and conventions: docs/import.md.

  --layout L              robotcar | nordland | generic; SPEC is then
                            robotcar  a traversal folder <date>/ (<camera>/*.png raw
                                      Bayer, <camera>.timestamps, gps/ins.csv)
                            nordland  FRAMES_DIR or FRAMES_DIR,GPS_CSV (columns frame or
                                      timestamp, latitude, longitude)
                            generic   IMAGE_DIR,POSES_CSV or DESCRIPTORS.npy,POSES_CSV
                                      (columns timestamp,x,y,z,yaw or timestamp,lat,lon;
                                      one row per image sorted by name, or per .npy row)
  --reference NAME=SPEC   a reference traversal (repeatable; the first makes the places)
  --query NAME=SPEC       a query traversal (repeatable): DIR/NAME.bag with the images
                          (original stamps) on /camera/image_raw, /vpr/query_pose
                          (PoseStamped, frame map) and /vpr/ground_truth
  --out DIR               where the sets and bags go (created); an existing set or bag of
                          the same name is replaced whole, and only once all are written
  --condition NAME=TEXT   condition label of reference NAME (default: NAME)
  --distance euclidean|cosine   the distance the sets are meant for (recorded in them)
  --resize WxH            resize every image (pixels) before describing and in the bags
Options:
)" + OptionsUsage(ImportOptionsTable().Infos()) +
         R"(Image descriptor of the reference sets (and of the queries with --query-descriptors):
)" + DescriberUsage() +
         R"(  -h, --help              this help
Exit status 2 with one line naming the problem on bad arguments or input; nothing is
written then.
)";
}

ImportArgs ParseImportArgs(int argc, char** argv) {
  ImportArgs a;
  bool layout_given = false;
  FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--layout") {
      a.layout = ParseDatasetFolders(v);
      layout_given = true;
    } else if (f == "--reference") {
      a.references.push_back(ParseNamedSpec(f, v));
    } else if (f == "--query") {
      a.queries.push_back(ParseNamedSpec(f, v));
    } else if (f == "--out") {
      a.out_dir = v;
    } else if (f == "--condition") {
      const NamedSpec c = ParseNamedSpec(f, v);
      a.conditions[c.name] = c.spec;
    } else if (f == "--distance") {
      a.distance = ToString(ForFlag(f, [&] { return ParseDistanceMetric(v); }));
    } else if (f == "--resize") {
      a.resize = ParseSize(f, v);
    } else if (ImportOptionsTable().SetFromFlag(f, v, &a.options)) {
      a.flags_given.push_back(OptionNameFromFlag(f));
    } else if (ParseDescriberFlag(f, v, &a.describer)) {
      if (a.describer_flag.empty()) a.describer_flag = f;
    } else {
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
    }
  }
  a.help = flags.help();
  if (a.help) return a;
  if (!layout_given) throw std::invalid_argument("no --layout robotcar|nordland|generic given");
  CheckCombination(a);
  return a;
}

}  // namespace tools
}  // namespace bsf_vpr
