#include "src/tools/evaluate/evaluate_ground_truth.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"

namespace bsf_vpr {
namespace tools {
namespace {

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) {
    const size_t b = cell.find_first_not_of(" \t");
    const size_t e = cell.find_last_not_of(" \t");
    cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
  }
  if (!line.empty() && line.back() == ',') cells.push_back("");
  return cells;
}

std::string Joined(const std::vector<std::string>& cells) {
  std::string s;
  for (size_t k = 0; k < cells.size(); ++k) s += (k ? "," : "") + cells[k];
  return s;
}

// A finite number, or nullopt.
std::optional<double> Number(const std::string& text) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used != text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string Metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

}  // namespace

std::vector<PlacePose> ReadQueryPosesCsv(const std::string& path, int num_queries) {
  std::istringstream in(ReadFile(path));
  const std::string what = "query poses '" + path + "'";
  int line_no = 0;
  auto fail = [&](const std::string& problem) {
    throw std::invalid_argument(what + " line " + std::to_string(line_no) + ": " + problem);
  };
  std::string line;
  bool by_timestamp = false, have_header = false;
  std::vector<PlacePose> poses;
  double last_stamp = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    const std::vector<std::string> cells = SplitCells(line);
    if (!have_header) {
      const std::string header = Joined(cells);
      if (std::find(cells.begin(), cells.end(), "lat") != cells.end() ||
          std::find(cells.begin(), cells.end(), "lon") != cells.end()) {
        fail(
            "latitude/longitude are not accepted: the reference poses are metres in their own "
            "frame; give the query poses as x,y in that frame ('query,x,y,z,yaw')");
      }
      if (header != "query,x,y,z,yaw" && header != "timestamp,x,y,z,yaw") {
        fail("expected the header 'query,x,y,z,yaw' or 'timestamp,x,y,z,yaw', got '" + line + "'");
      }
      by_timestamp = cells[0] == "timestamp";
      have_header = true;
      continue;
    }
    if (cells.size() != 5) {
      fail("expected 5 values (" + std::string(by_timestamp ? "timestamp" : "query") +
           ",x,y,z,yaw), got '" + line + "'");
    }
    double v[5];
    for (size_t k = 0; k < 5; ++k) {
      const std::optional<double> n = Number(cells[k]);
      if (!n) fail("'" + cells[k] + "' is not a finite number");
      v[k] = *n;
    }
    const int row = static_cast<int>(poses.size());
    if (!by_timestamp && v[0] != row) {
      fail("query " + cells[0] + " where query " + std::to_string(row) +
           " was expected (one row per query, in order)");
    }
    if (by_timestamp && row > 0 && !(v[0] > last_stamp)) {
      fail("timestamp " + cells[0] +
           " is not after the row before (one row per query, in time order)");
    }
    last_stamp = v[0];
    poses.push_back(PlacePose{v[1], v[2], v[3], v[4]});
  }
  if (!have_header) {
    throw std::invalid_argument(what + " is empty: expected the header 'query,x,y,z,yaw' or " +
                                "'timestamp,x,y,z,yaw' and one row per query");
  }
  if (static_cast<int>(poses.size()) != num_queries) {
    throw std::invalid_argument(what + " has " + std::to_string(poses.size()) + " rows for " +
                                std::to_string(num_queries) +
                                " queries (one row per query, in order)");
  }
  return poses;
}

std::vector<std::optional<PlacePose>> PlacePosesOf(const ReferenceSets& map) {
  const std::vector<std::optional<PlacePose>>& poses = map.place_poses();
  if (std::none_of(poses.begin(), poses.end(), [](const auto& p) { return p.has_value(); })) {
    throw std::invalid_argument("--tolerance-m needs place poses: no reference set has 'poses'");
  }
  return poses;
}

std::vector<std::optional<PlacePose>> NodePlacePoses(const std::vector<NamedPath>& references,
                                                     const std::vector<std::string>& set_names,
                                                     int num_places) {
  std::map<std::string, std::string> path_of;
  std::string sets;
  for (const std::string& s : set_names) sets += (sets.empty() ? "" : ", ") + s;
  for (const NamedPath& r : references) {
    if (std::find(set_names.begin(), set_names.end(), r.name) == set_names.end()) {
      throw std::invalid_argument("--reference " + r.name + "=" + r.path +
                                  ": the node of this replay had no set '" + r.name +
                                  "' (its sets: " + sets + ")");
    }
    if (!path_of.emplace(r.name, r.path).second) {
      throw std::invalid_argument("--reference " + r.name + " is given twice");
    }
  }
  ReferenceSets map;
  for (const std::string& name : set_names) {
    const auto it = path_of.find(name);
    if (it == path_of.end()) {
      throw std::invalid_argument(
          "--tolerance-m with --results-bag needs the place poses of every "
          "set the node had loaded: give --reference " +
          name + "=PATH.yaml (its sets: " + sets + ")");
    }
    map.Add(LoadReferenceSetFile(it->second, name));
  }
  if (map.num_places() != num_places) {
    throw std::invalid_argument("the reference sets given make " +
                                std::to_string(map.num_places()) + " places, the beliefs have " +
                                std::to_string(num_places) +
                                ": give the reference-set YAMLs the node had loaded");
  }
  return PlacePosesOf(map);
}

std::string DescribeMetricTruth(double tolerance_m, const std::string& query_source,
                                const std::vector<std::optional<PlacePose>>& place_poses) {
  const auto with_pose = std::count_if(place_poses.begin(), place_poses.end(),
                                       [](const auto& p) { return p.has_value(); });
  return "a match within " + Metres(tolerance_m) +
         " m of the query's pose is correct (planar distance, --tolerance-m " +
         Metres(tolerance_m) + "); query poses from " + query_source + "; place poses for " +
         std::to_string(with_pose) + " of " + std::to_string(place_poses.size()) +
         " places (a place without one is never correct)";
}

std::string DescribeFrameTruth(int tolerance_frames) {
  const std::string k = std::to_string(tolerance_frames);
  return "query q shows place q; a match within " + k + " places is correct (--tolerance " + k +
         ")";
}

std::string CountTrueMatches(const GroundTruth& truth) {
  return std::to_string(truth.NumWithTrueMatch()) + " of " + std::to_string(truth.num_queries()) +
         " queries have a true match";
}

}  // namespace tools
}  // namespace bsf_vpr
