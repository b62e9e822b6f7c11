#include "conversions.h"

#include <cmath>

namespace bsf_vpr {

void ToBeliefMsg(const Recognition& r, const PlaceRecognizer& recognizer, int belief_top_k,
                 Belief* out) {
  const PlaceBelief& b = r.belief;
  const ReferenceMap& map = recognizer.map();
  out->method = recognizer.options().method;
  out->gamma = recognizer.options().method_options.selection.gamma_fraction;
  out->num_places = map.num_places();
  out->place_ids.clear();
  out->posterior.clear();
  if (b.log_posterior.size() > 0) {
    if (belief_top_k == 0) {
      out->place_ids.resize(static_cast<size_t>(b.log_posterior.size()));
      out->posterior.resize(out->place_ids.size());
      for (Eigen::Index i = 0; i < b.log_posterior.size(); ++i) {
        out->place_ids[static_cast<size_t>(i)] = static_cast<int32_t>(i);
        out->posterior[static_cast<size_t>(i)] = static_cast<float>(std::exp(b.log_posterior(i)));
      }
    } else {
      for (int place : TopK(b.log_posterior, belief_top_k)) {
        out->place_ids.push_back(place);
        out->posterior.push_back(static_cast<float>(std::exp(b.log_posterior(place))));
      }
    }
  } else {
    out->place_ids.assign(b.top_places.begin(), b.top_places.end());
  }
  out->set_names.clear();
  out->set_min_distances.clear();
  for (int u = 0; u < map.num_sets(); ++u) {
    out->set_names.push_back(map.set(u).name());
    out->set_min_distances.push_back(b.selection.set_stats.at(static_cast<size_t>(u)).min);
  }
  out->selected_sets.clear();
  for (int u : b.selection.selected) out->selected_sets.push_back(map.set(u).name());
  out->used_sets.clear();
  for (int u : b.used_sets) out->used_sets.push_back(map.set(u).name());
  out->set_weights.assign(b.set_weights.begin(), b.set_weights.end());
  out->match = b.match;
  out->confidence = b.confidence;
  out->accepted = b.accepted;
}

geometry_msgs::Pose ToPoseMsg(const PlacePose& pose) {
  geometry_msgs::Pose p;
  p.position.x = pose.x_m;
  p.position.y = pose.y_m;
  p.position.z = pose.z_m;
  p.orientation.z = std::sin(pose.yaw_rad / 2);
  p.orientation.w = std::cos(pose.yaw_rad / 2);
  return p;
}

void ToMatchMsg(const Recognition& r, const ReferenceMap& map, Match* out) {
  out->place_id = r.belief.match;
  out->confidence = r.belief.confidence;
  out->reference_set = r.closest_set >= 0 ? map.set(r.closest_set).name() : "";
  const std::optional<PlacePose> pose = map.PoseOf(r.belief.match);
  out->has_pose = pose.has_value();
  out->pose = pose ? ToPoseMsg(*pose) : geometry_msgs::Pose();
  if (!pose) out->pose.orientation.w = 1;
}

geometry_msgs::TransformStamped ToPlaceTransformMsg(const Match& match, const ros::Time& stamp,
                                                    const std::string& place_frame) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = match.header.frame_id;
  t.child_frame_id = place_frame;
  t.transform.translation.x = match.pose.position.x;
  t.transform.translation.y = match.pose.position.y;
  t.transform.translation.z = match.pose.position.z;
  t.transform.rotation = match.pose.orientation;
  return t;
}

ReferenceSetInfo ToInfoMsg(const StoredReferenceSet& set) {
  ReferenceSetInfo info;
  info.name = set.name();
  info.condition = set.condition();
  info.descriptor_type = set.descriptor_type();
  info.num_places = set.size();
  info.dimension = set.dimension();
  info.memory_bytes = set.MemoryBytes();
  info.storage = ToString(set.precision());
  return info;
}

}  // namespace bsf_vpr
