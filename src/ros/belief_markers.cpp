#include "belief_markers.h"

#include <algorithm>

namespace bsf_vpr {
namespace {

geometry_msgs::Point PlacePoint(const ReferenceMap& map, int place, double spacing_m) {
  geometry_msgs::Point p;
  if (const auto pose = map.PoseOf(place)) {
    p.x = pose->x_m;
    p.y = pose->y_m;
    p.z = pose->z_m;
  } else {
    p.x = place * spacing_m;
  }
  return p;
}

visualization_msgs::Marker Base(const Belief& belief, const std::string& frame,
                                const std::string& ns, int type, double scale) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.header.stamp = belief.header.stamp;
  m.ns = ns;
  m.id = 0;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1;
  m.scale.x = m.scale.y = m.scale.z = scale;
  m.color.a = 1;
  return m;
}

}  // namespace

visualization_msgs::MarkerArray MakeBeliefMarkers(const ReferenceMap& map, const Belief& belief,
                                                  const std::string& frame, double spacing_m) {
  visualization_msgs::MarkerArray out;
  const double s = spacing_m;
  visualization_msgs::Marker route =
      Base(belief, frame, "route", visualization_msgs::Marker::POINTS, 0.3 * s);
  route.color.r = route.color.g = route.color.b = 0.6f;
  route.color.a = 0.5f;
  for (int i = 0; i < map.num_places(); ++i) route.points.push_back(PlacePoint(map, i, s));
  out.markers.push_back(route);

  visualization_msgs::Marker belief_m =
      Base(belief, frame, "belief", visualization_msgs::Marker::SPHERE_LIST, 0.8 * s);
  const float max_p =
      belief.posterior.empty()
          ? 1.0f
          : std::max(1e-12f, *std::max_element(belief.posterior.begin(), belief.posterior.end()));
  for (size_t k = 0; k < belief.place_ids.size(); ++k) {
    // Distance methods rank places without a posterior: colour by rank instead.
    const float level =
        belief.posterior.empty()
            ? 1.0f - static_cast<float>(k) / static_cast<float>(belief.place_ids.size())
            : belief.posterior[k] / max_p;
    if (level < 0.01f) continue;  // keep the marker small: skip negligible places
    belief_m.points.push_back(PlacePoint(map, belief.place_ids[k], s));
    std_msgs::ColorRGBA c;
    c.r = level;
    c.b = 1.0f - level;
    c.a = 0.3f + 0.7f * level;
    belief_m.colors.push_back(c);
  }
  out.markers.push_back(belief_m);

  visualization_msgs::Marker match =
      Base(belief, frame, "match", visualization_msgs::Marker::SPHERE, 2.0 * s);
  match.pose.position = PlacePoint(map, belief.match, s);
  match.color.g = belief.accepted ? 1.0f : 0.5f;  // green, or orange when not accepted
  match.color.r = belief.accepted ? 0.0f : 1.0f;
  match.color.b = 0.0f;
  out.markers.push_back(match);
  return out;
}

}  // namespace bsf_vpr
