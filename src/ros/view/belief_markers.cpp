#include "src/ros/view/belief_markers.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace bsf_vpr {
namespace {

using visualization_msgs::Marker;

std_msgs::ColorRGBA Rgba(float r, float g, float b, float a = 1.0f) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

// Light purple (low) through pink to light yellow (the best place): reads on the dark
// background of the shipped view and differs from the green, orange and cyan markers.
std_msgs::ColorRGBA LevelColour(double level) {
  const double stops[3][3] = {{0.55, 0.35, 0.95}, {0.95, 0.35, 0.55}, {1.00, 0.85, 0.35}};
  const double t = std::clamp(level, 0.0, 1.0) * 2;
  const int i = std::min(1, static_cast<int>(t));
  const double f = t - i;
  auto mix = [&](int k) { return static_cast<float>(stops[i][k] * (1 - f) + stops[i + 1][k] * f); };
  return Rgba(mix(0), mix(1), mix(2));
}

const std_msgs::ColorRGBA kAccepted = Rgba(0.15f, 0.85f, 0.25f);
const std_msgs::ColorRGBA kNotAccepted = Rgba(1.0f, 0.55f, 0.0f);
const std_msgs::ColorRGBA kTruePlace = Rgba(0.0f, 0.9f, 1.0f, 0.7f);
const std_msgs::ColorRGBA kText = Rgba(1.0f, 1.0f, 1.0f);

Marker Base(const std_msgs::Header& header, const BeliefViewOptions& options, const std::string& ns,
            int type) {
  Marker m;
  m.header.frame_id = options.map_frame;
  m.header.stamp = header.stamp;
  m.ns = ns;
  m.id = 0;
  m.type = type;
  m.action = Marker::ADD;
  m.pose.orientation.w = 1;
  m.scale.x = m.scale.y = m.scale.z = 1;
  m.color = kText;
  return m;
}

geometry_msgs::Point ToPoint(const Eigen::Vector3d& v) {
  geometry_msgs::Point p;
  p.x = v.x();
  p.y = v.y();
  p.z = v.z();
  return p;
}

Marker Text(const Belief& belief, const BeliefViewOptions& options, const std::string& ns, int id,
            const std::string& text, const Eigen::Vector3d& at, double height) {
  Marker m = Base(belief.header, options, ns, Marker::TEXT_VIEW_FACING);
  m.id = id;
  m.text = text;
  m.pose.position = ToPoint(at);
  m.scale.x = m.scale.y = m.scale.z = height;
  return m;
}

// Each place's level in [0, 1] (0: not drawn): its posterior relative to the best place
// (linear or log), or, for a ranked belief without posterior, 1 - rank / count.
std::vector<double> PlaceLevels(const Belief& belief, int num_places, bool log_scale) {
  std::vector<double> level(static_cast<size_t>(num_places), 0.0);
  const size_t n = belief.place_ids.size();
  float best = 0;
  for (float p : belief.posterior) best = std::max(best, p);
  for (size_t k = 0; k < n; ++k) {
    const int place = belief.place_ids[k];
    if (place < 0 || place >= num_places) continue;
    double v;
    if (belief.posterior.empty()) {
      v = 1.0 - static_cast<double>(k) / static_cast<double>(n);
    } else if (best <= 0 || k >= belief.posterior.size()) {
      v = 0;
    } else if (log_scale) {
      const double ratio = belief.posterior[k] / best;
      v = ratio > 0 ? 1.0 + std::log10(ratio) / kLogDecades : 0.0;
    } else {
      v = belief.posterior[k] / best;
    }
    level[static_cast<size_t>(place)] = std::clamp(v, 0.0, 1.0);
  }
  return level;
}

std::string Joined(const std::vector<std::string>& items, size_t max_chars) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) {
    const std::string next = (i ? ", " : "") + items[i];
    if (out.size() + next.size() > max_chars) {
      return out + " +" + std::to_string(items.size() - i) + " more";
    }
    out += next;
  }
  return out.empty() ? "(none)" : out;
}

}  // namespace

RouteDrawing MakeRouteDrawing(const PlaceLayout& places, const BeliefViewOptions& options) {
  RouteDrawing route;
  const int n = places.num_places();
  const auto& poses = places.place_poses();
  route.from_poses =
      n > 0 && std::all_of(poses.begin(), poses.end(), [](const auto& p) { return p.has_value(); });
  if (route.from_poses) {
    for (const auto& p : poses) route.points.emplace_back(p->x_m, p->y_m, p->z_m);
    route.spacing_m = places.MedianPlaceSpacing().value_or(0.0);
  } else {
    route.spacing_m = options.marker_spacing_m > 0 ? options.marker_spacing_m
                       : n > 1                      ? options.view_size_m / (n - 1)
                                                    : 0.0;
    for (int k = 0; k < n; ++k) route.points.emplace_back(k * route.spacing_m, 0.0, 0.0);
  }
  if (n > 0) {
    Eigen::Vector3d lo = route.points[0], hi = route.points[0];
    for (const Eigen::Vector3d& p : route.points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    route.centre = (lo + hi) / 2;
    route.centre.z() = lo.z();
    route.extent_m = std::max(hi.x() - lo.x(), hi.y() - lo.y());
  }
  route.fits_view = route.extent_m <= options.view_size_m * (1 + 1e-9);
  // A single place (or places at one point) has no extent: a tenth of the view.
  route.scale_m = route.extent_m > 0 ? std::min(route.extent_m, options.view_size_m)
                                       : options.view_size_m / 10;
  if (!route.fits_view) {  // shrunk to fit the view: every place in sight
    route.draw_scale = options.view_size_m / route.extent_m;
    for (Eigen::Vector3d& p : route.points) {
      p.head<2>() = route.centre.head<2>() + route.draw_scale * (p - route.centre).head<2>();
    }
    route.spacing_m *= route.draw_scale;
  }
  return route;
}

int PlaceNumberStep(int num_places) {
  for (long decade = 1;; decade *= 10) {
    for (long m : {1, 2, 5}) {
      if ((num_places - 1) / (m * decade) <= kPlaceNumbers || m * decade >= num_places) {
        return static_cast<int>(m * decade);
      }
    }
  }
}

MarkerSizes SizesFor(const RouteDrawing& route, int places_per_bar) {
  const double s = route.scale_m;
  MarkerSizes z;
  z.bar_height_m = 0.3 * s;
  z.bar_width_m = std::clamp(0.8 * route.spacing_m * places_per_bar, s / 150, s / 40);
  z.route_width_m = s / 500;
  z.pin_diameter_m = std::max(s / 45, 1.3 * z.bar_width_m);
  z.true_place_m = 1.2 * z.pin_diameter_m;
  z.label_height_m = s / 28;
  z.legend_height_m = s / 45;
  return z;
}

Eigen::Vector3d ViewFocus(const RouteDrawing& route) { return route.centre; }

std::vector<std::string> BeliefLabelLines(const Belief& belief, bool probabilistic) {
  std::vector<std::string> lines;
  char buf[160];
  // Off the map more likely than not: the place is only the best guess of a robot lost.
  const bool off_map = !belief.accepted && belief.off_map_probability > 0.5;
  std::snprintf(buf, sizeof(buf), "place %d of %d: %s", belief.match, belief.num_places,
                belief.accepted ? "ACCEPTED"
                : off_map       ? "not accepted, OFF THE MAP"
                                : "not accepted");
  lines.emplace_back(buf);
  if (probabilistic && belief.off_map_probability > 0) {
    std::snprintf(buf, sizeof(buf), "no place of the map: p %.3f", belief.off_map_probability);
    lines.emplace_back(buf);
  }
  if (probabilistic) {
    const double p = 1.0 / (1.0 + std::exp(-belief.confidence));
    std::snprintf(buf, sizeof(buf), "%s: p %.3f (log-odds %.2f)", belief.method.c_str(), p,
                  belief.confidence);
  } else {
    std::snprintf(buf, sizeof(buf), "%s: distance %.4g", belief.method.c_str(), -belief.confidence);
  }
  lines.emplace_back(buf);
  lines.push_back("selected: " + Joined(belief.selected_sets, 60));
  // Weights other than 0 and 1 (fusion mixture): what each set contributed.
  const bool graded = std::any_of(belief.set_weights.begin(), belief.set_weights.end(),
                                  [](float w) { return w > 0 && w < 1; });
  if (graded && belief.set_weights.size() == belief.set_names.size()) {
    std::vector<std::string> weights;
    for (size_t u = 0; u < belief.set_names.size(); ++u) {
      std::snprintf(buf, sizeof(buf), "%s %.2f", belief.set_names[u].c_str(),
                    belief.set_weights[u]);
      weights.emplace_back(buf);
    }
    lines.push_back("weights: " + Joined(weights, 60));
  }
  return lines;
}

std::optional<Marker> TruePlacesMarker(const RouteDrawing& route,
                                       const std::vector<int>& true_places,
                                       const std_msgs::Header& header,
                                       const BeliefViewOptions& options) {
  const int n = static_cast<int>(route.points.size());
  Marker truth = Base(header, options, "true_places", Marker::SPHERE_LIST);
  const double size = SizesFor(route, (n + kMaxBars - 1) / kMaxBars).true_place_m;
  truth.scale.x = truth.scale.y = truth.scale.z = size;
  truth.color = kTruePlace;
  for (int place : true_places) {
    if (place >= 0 && place < n)
      truth.points.push_back(ToPoint(route.points[static_cast<size_t>(place)]));
  }
  if (truth.points.empty()) return std::nullopt;
  return truth;
}

namespace {

// The match: a pin at its place (green accepted, orange not) and its label.
void AddMatchMarkers(const RouteDrawing& route, const Belief& belief, const MarkerSizes& size,
                     bool probabilistic, const BeliefViewOptions& options,
                     visualization_msgs::MarkerArray* out) {
  auto at = [&](int place) { return route.points[static_cast<size_t>(place)]; };
  const double pin_height = 1.1 * size.bar_height_m;
  // A needle half the bar's width (the bar it stands in stays visible) with a round head above
  // the bars.
  Marker pin = Base(belief.header, options, "match", Marker::CYLINDER);
  pin.pose.position = ToPoint(at(belief.match) + Eigen::Vector3d(0, 0, pin_height / 2));
  pin.scale.x = pin.scale.y = size.bar_width_m / 2;
  pin.scale.z = pin_height;
  pin.color = belief.accepted ? kAccepted : kNotAccepted;
  out->markers.push_back(pin);
  Marker head = pin;
  head.id = 1;
  head.type = Marker::SPHERE;
  head.pose.position.z = at(belief.match).z() + pin_height;
  head.scale.x = head.scale.y = head.scale.z = size.pin_diameter_m;
  out->markers.push_back(head);
  std::string text;
  for (const std::string& line : BeliefLabelLines(belief, probabilistic)) {
    text += (text.empty() ? "" : "\n") + line;
  }
  const double lines = static_cast<double>(std::count(text.begin(), text.end(), '\n') + 1);
  Eigen::Vector3d anchor = at(belief.match);
  {
    // The text is centred on its anchor: at an end of the route half of it would lie
    // outside the view (the place number cut off). The anchor moves inwards until the
    // longest line fits (a character is about 0.6 of the text's height wide).
    size_t longest = 0;
    for (const std::string& line : BeliefLabelLines(belief, probabilistic)) {
      longest = std::max(longest, line.size());
    }
    const double half_text = 0.3 * size.label_height_m * static_cast<double>(longest);
    const double room = std::max(0.0, options.view_size_m / 2 - half_text);
    for (int k : {0, 1}) {
      anchor[k] = std::clamp(anchor[k], route.centre[k] - room, route.centre[k] + room);
    }
  }
  out->markers.push_back(
      Text(belief, options, "label", 0, text,
           anchor + Eigen::Vector3d(0, 0, pin_height + (lines / 2 + 0.5) * size.label_height_m),
           size.label_height_m));
}

// The legend, the route's ends and numbers along it.
void AddLegend(const RouteDrawing& route, const Belief& belief, const MarkerSizes& size,
               const BeliefViewOptions& options, visualization_msgs::MarkerArray* out) {
  const int n = static_cast<int>(route.points.size());
  auto at = [&](int place) { return route.points[static_cast<size_t>(place)]; };
  std::string legend =
      (belief.posterior.empty()
           ? std::string("bars: rank of the place (distance method)")
           : std::string("bars: P(place)") + (options.log_scale ? ", log scale" : "")) +
      "\npin: match (green accepted, orange not)\ncyan: true place";
  if (route.draw_scale < 1) {
    char shrunk[120];
    std::snprintf(shrunk, sizeof(shrunk), "\nroute %.0f m drawn %.3g times smaller", route.extent_m,
                  1 / route.draw_scale);
    legend += shrunk;
  }
  const Eigen::Vector3d below(0, -0.08 * route.scale_m, 0);
  out->markers.push_back(
      Text(belief, options, "legend", 0, legend, route.centre + 2 * below, size.legend_height_m));
  out->markers.push_back(
      Text(belief, options, "legend", 1, "0", at(0) + below / 2, size.legend_height_m));
  out->markers.push_back(Text(belief, options, "legend", 2, std::to_string(n - 1),
                             at(n - 1) + below / 2, size.legend_height_m));
  // Numbers along the route, beside the places (0 and n - 1 are the legend's).
  const int step = PlaceNumberStep(n);
  for (int place = step, id = 0; place < n - 1; place += step, ++id) {
    out->markers.push_back(Text(belief, options, "place_numbers", id, std::to_string(place),
                               at(place) + below / 2, size.legend_height_m));
  }
}

}  // namespace

visualization_msgs::MarkerArray MakeBeliefMarkers(const RouteDrawing& route, const Belief& belief,
                                                  const std::vector<int>& true_places,
                                                  bool probabilistic,
                                                  const BeliefViewOptions& options) {
  visualization_msgs::MarkerArray out;
  Marker clear;
  clear.action = Marker::DELETEALL;
  out.markers.push_back(clear);
  const int n = static_cast<int>(route.points.size());
  if (n == 0) return out;
  const int per_bar = (n + kMaxBars - 1) / kMaxBars;
  const MarkerSizes size = SizesFor(route, per_bar);
  auto at = [&](int place) { return route.points[static_cast<size_t>(place)]; };

  Marker line = Base(belief.header, options, "route", Marker::LINE_LIST);
  line.scale.x = size.route_width_m;
  line.color = Rgba(0.7f, 0.7f, 0.7f);
  const double jump = 5 * std::max(route.spacing_m, 1e-9) * per_bar;
  for (int k = per_bar; k < n; k += per_bar) {
    if ((at(k) - at(k - per_bar)).norm() > jump) continue;
    line.points.push_back(ToPoint(at(k - per_bar)));
    line.points.push_back(ToPoint(at(k)));
  }
  out.markers.push_back(line);

  // Bars (vertical lines, seen from the side) and their footprints (squares, seen from
  // above), one per bin of per_bar consecutive places, at the bin's best place.
  const std::vector<double> level = PlaceLevels(belief, n, options.log_scale);
  Marker bars = Base(belief.header, options, "belief", Marker::LINE_LIST);
  bars.scale.x = size.bar_width_m;
  Marker feet = Base(belief.header, options, "belief", Marker::CUBE_LIST);
  feet.id = 1;
  feet.scale.x = feet.scale.y = size.bar_width_m;
  feet.scale.z = size.bar_width_m / 4;
  for (int first = 0; first < n; first += per_bar) {
    const int last = std::min(n, first + per_bar);
    const int best = static_cast<int>(
        std::max_element(level.begin() + first, level.begin() + last) - level.begin());
    const double v = level[static_cast<size_t>(best)];
    if (v <= 0.005) continue;
    const std_msgs::ColorRGBA c = LevelColour(v);
    bars.points.push_back(ToPoint(at(best)));
    bars.points.push_back(ToPoint(at(best) + Eigen::Vector3d(0, 0, v * size.bar_height_m)));
    bars.colors.insert(bars.colors.end(), {c, c});
    feet.points.push_back(ToPoint(at(best)));
    feet.colors.push_back(c);
  }
  out.markers.push_back(bars);
  out.markers.push_back(feet);

  if (belief.match >= 0 && belief.match < n) {
    AddMatchMarkers(route, belief, size, probabilistic, options, &out);
  }

  if (auto truth = TruePlacesMarker(route, true_places, belief.header, options)) {
    out.markers.push_back(*truth);
  }

  AddLegend(route, belief, size, options, &out);
  return out;
}

}  // namespace bsf_vpr
