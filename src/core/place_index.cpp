#include "bsf_vpr/core/place_index.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <unordered_map>

namespace bsf_vpr {
namespace {

constexpr double kPi = 3.14159265358979323846;

void CheckPoses(const std::vector<PlacePose>& poses, const char* what) {
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!IsFinite(poses[i])) {
      throw std::invalid_argument(std::string(what) + " " + std::to_string(i) +
                                  " has a pose that is not finite");
    }
  }
}

// Places over a uniform grid of cells `cell_m` wide, for the places near a point.
class PlaceGrid {
 public:
  PlaceGrid(const std::vector<std::optional<PlacePose>>& poses, double cell_m) : cell_(cell_m) {
    for (size_t i = 0; i < poses.size(); ++i) {
      if (poses[i])
        cells_[Key(Cell(poses[i]->x_m), Cell(poses[i]->y_m))].push_back(static_cast<int>(i));
    }
  }
  // Calls f(place) for the places in the 3 x 3 cells around (x, y).
  template <typename F>
  void ForNear(double x, double y, F f) const {
    const int64_t cx = Cell(x), cy = Cell(y);
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(Key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (int place : it->second) f(place);
      }
    }
  }

 private:
  int64_t Cell(double v) const { return static_cast<int64_t>(std::floor(v / cell_)); }
  static uint64_t Key(int64_t x, int64_t y) {
    return (static_cast<uint64_t>(x) << 32) ^ (static_cast<uint64_t>(y) & 0xffffffffu);
  }
  double cell_;
  std::unordered_map<uint64_t, std::vector<int>> cells_;
};

}  // namespace

void PlaceIndexOptions::Validate() const { PlaceIndexOptionsTable().CheckValues(*this); }

const OptionTable<PlaceIndexOptions>& PlaceIndexOptionsTable() {
  static const OptionTable<PlaceIndexOptions> kTable =
      OptionTable<PlaceIndexOptions>()
          .Add(
              "place_spacing_m", [](auto& o) -> auto& { return o.place_spacing_m; },
              "distance between places along a route that makes new places (the paper: 1)", "m",
              Finite(Above(0)))
          .Add(
              "association_radius_m", [](auto& o) -> auto& { return o.association_radius_m; },
              "a traversal's frame describes a place of the map when it lies within this "
              "distance of it (the nearest such frame)",
              "m", Finite(Above(0)))
          .Add(
              "max_yaw_difference_deg", [](auto& o) -> auto& { return o.max_yaw_difference_deg; },
              "a frame whose heading differs more from a place's is not a view of it (a place "
              "seen in the opposite direction is another place)",
              "degrees", Between(0, 180))
          .Add(
              "add_new_places", [](auto& o) -> auto& { return o.add_new_places; },
              "route of a traversal beyond the map's places becomes new places (else it is "
              "left out)");
  return kTable;
}

double PlanarDistance(const PlacePose& a, const PlacePose& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m);
}

double YawDifference(double a_rad, double b_rad) {
  double d = std::fmod(std::abs(a_rad - b_rad), 2 * kPi);
  return d > kPi ? 2 * kPi - d : d;
}

PlaceAssignment MakePlacesAlongRoute(const std::vector<PlacePose>& frame_poses,
                                     const PlaceIndexOptions& options, int first_place_id) {
  options.Validate();
  if (frame_poses.empty()) throw std::invalid_argument("the traversal has no frames");
  CheckPoses(frame_poses, "frame");
  // Arc length at every frame.
  std::vector<double> s(frame_poses.size(), 0.0);
  for (size_t i = 1; i < frame_poses.size(); ++i) {
    s[i] = s[i - 1] + PlanarDistance(frame_poses[i - 1], frame_poses[i]);
  }
  PlaceAssignment out;
  int last_frame = -1;
  size_t j = 0;  // segment [j, j + 1] holds the target
  const double length = s.back();
  for (int64_t k = 0; static_cast<double>(k) * options.place_spacing_m <= length + 1e-9; ++k) {
    const double target = static_cast<double>(k) * options.place_spacing_m;
    while (j + 1 < s.size() && s[j + 1] < target) ++j;
    int frame = static_cast<int>(j);
    if (j + 1 < s.size() && std::abs(s[j + 1] - target) < std::abs(s[j] - target)) {
      frame = static_cast<int>(j + 1);
    }
    if (frame == last_frame) continue;  // frames sparser than places: one place per frame
    last_frame = frame;
    out.place_ids.push_back(first_place_id + static_cast<int>(out.frames.size()));
    out.frames.push_back(frame);
    out.place_poses.push_back(frame_poses[static_cast<size_t>(frame)]);
  }
  out.new_places = static_cast<int>(out.place_ids.size());
  return out;
}

PlaceAssignment AssociateWithPlaces(const std::vector<PlacePose>& frame_poses,
                                    const std::vector<std::optional<PlacePose>>& place_poses,
                                    const PlaceIndexOptions& options) {
  options.Validate();
  CheckPoses(frame_poses, "frame");
  const double radius = options.association_radius_m;
  const double max_yaw_rad = options.max_yaw_difference_deg * kPi / 180;
  const PlaceGrid grid(place_poses, radius);
  std::vector<int> best_frame(place_poses.size(), -1);
  std::vector<double> best_distance(place_poses.size(), 0.0);
  std::vector<bool> near_a_place(frame_poses.size(), false);
  for (size_t f = 0; f < frame_poses.size(); ++f) {
    const PlacePose& fp = frame_poses[f];
    grid.ForNear(fp.x_m, fp.y_m, [&](int place) {
      const PlacePose& pp = *place_poses[static_cast<size_t>(place)];
      const double d = PlanarDistance(fp, pp);
      if (d > radius || YawDifference(fp.yaw_rad, pp.yaw_rad) > max_yaw_rad) {
        return;
      }
      near_a_place[f] = true;
      const size_t p = static_cast<size_t>(place);
      if (best_frame[p] < 0 || d < best_distance[p]) {
        best_frame[p] = static_cast<int>(f);
        best_distance[p] = d;
      }
    });
  }
  PlaceAssignment out;
  for (size_t p = 0; p < place_poses.size(); ++p) {
    if (best_frame[p] < 0) continue;
    out.place_ids.push_back(static_cast<int>(p));
    out.frames.push_back(best_frame[p]);
    out.place_poses.push_back(frame_poses[static_cast<size_t>(best_frame[p])]);
  }
  if (!options.add_new_places) return out;
  // Each stretch of frames near no place becomes new places along its own route.
  int next_id = static_cast<int>(place_poses.size());
  for (size_t start = 0; start < frame_poses.size();) {
    if (near_a_place[start]) {
      ++start;
      continue;
    }
    size_t end = start;
    while (end < frame_poses.size() && !near_a_place[end]) ++end;
    const std::vector<PlacePose> stretch(frame_poses.begin() + static_cast<std::ptrdiff_t>(start),
                                         frame_poses.begin() + static_cast<std::ptrdiff_t>(end));
    const PlaceAssignment added = MakePlacesAlongRoute(stretch, options, next_id);
    for (size_t k = 0; k < added.place_ids.size(); ++k) {
      out.place_ids.push_back(added.place_ids[k]);
      out.frames.push_back(static_cast<int>(start) + added.frames[k]);
      out.place_poses.push_back(added.place_poses[k]);
    }
    next_id += added.new_places;
    out.new_places += added.new_places;
    start = end;
  }
  return out;
}

std::optional<PlacePose> InterpolatePose(const PoseTrack& track, double stamp_s, double max_gap_s) {
  const std::vector<double>& t = track.stamps_s;
  if (t.empty() || t.size() != track.poses.size() || !(stamp_s >= t.front()) ||
      !(stamp_s <= t.back())) {
    return std::nullopt;
  }
  const size_t hi = static_cast<size_t>(std::lower_bound(t.begin(), t.end(), stamp_s) - t.begin());
  if (t[hi] == stamp_s) return track.poses[hi];
  const size_t lo = hi - 1;
  if (t[hi] - t[lo] > max_gap_s) return std::nullopt;
  const double a = (stamp_s - t[lo]) / (t[hi] - t[lo]);
  const PlacePose& p = track.poses[lo];
  const PlacePose& q = track.poses[hi];
  double dyaw = std::remainder(q.yaw_rad - p.yaw_rad, 2 * kPi);  // the short way round
  PlacePose r;
  r.x_m = p.x_m + a * (q.x_m - p.x_m);
  r.y_m = p.y_m + a * (q.y_m - p.y_m);
  r.z_m = p.z_m + a * (q.z_m - p.z_m);
  r.yaw_rad = std::remainder(p.yaw_rad + a * dyaw, 2 * kPi);
  return r;
}

PlacePose LocalMetresFromLatLon(double latitude_deg, double longitude_deg,
                                double origin_latitude_deg, double origin_longitude_deg) {
  constexpr double kEarthRadiusM = 6371008.8;  // mean radius
  constexpr double kRad = kPi / 180;
  PlacePose p;
  p.x_m = (longitude_deg - origin_longitude_deg) * kRad * kEarthRadiusM *
          std::cos(origin_latitude_deg * kRad);
  p.y_m = (latitude_deg - origin_latitude_deg) * kRad * kEarthRadiusM;
  return p;
}

void HeadingsFromPath(std::vector<PlacePose>* poses, double min_step_m) {
  std::vector<PlacePose>& p = *poses;
  const size_t n = p.size();
  std::vector<double> yaw(n, 0.0);
  std::vector<bool> known(n, false);
  for (size_t i = 0; i < n; ++i) {
    // The first pose ahead at least min_step_m away (a stop longer than kLookahead frames
    // keeps the heading it had).
    constexpr size_t kLookahead = 1000;
    size_t j = i + 1;
    while (j < n && j - i < kLookahead && PlanarDistance(p[i], p[j]) < min_step_m) ++j;
    if (j < n && PlanarDistance(p[i], p[j]) >= min_step_m) {
      yaw[i] = std::atan2(p[j].y_m - p[i].y_m, p[j].x_m - p[i].x_m);
      known[i] = true;
    }
  }
  // Frames near the end (no pose far enough ahead) and stops keep the last heading.
  double last = 0;
  bool any = false;
  for (size_t i = 0; i < n; ++i) {
    if (known[i]) {
      last = yaw[i];
      any = true;
    }
    p[i].yaw_rad = any ? (known[i] ? yaw[i] : last) : 0;
  }
}

std::optional<PoseConflict> FindPoseConflict(const std::vector<std::optional<PlacePose>>& a,
                                             const std::vector<std::optional<PlacePose>>& b,
                                             double tolerance_m) {
  std::optional<PoseConflict> worst;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    if (!a[i] || !b[i]) continue;
    const double d = PlanarDistance(*a[i], *b[i]);
    if (d > tolerance_m && (!worst || d > worst->distance_m)) {
      worst = PoseConflict{static_cast<int>(i), d};
    }
  }
  return worst;
}

}  // namespace bsf_vpr
