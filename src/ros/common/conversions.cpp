#include "src/ros/common/conversions.h"

#include <cmath>

#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/sharding.h"
#include "bsf_vpr/map/set_loading.h"

namespace bsf_vpr {

void ToBeliefMsg(const Recognition& r, const PlaceLayout& layout, const PlaceDecider& decider,
                 int belief_top_k, Belief* out) {
  const PlaceBelief& b = r.belief;
  out->method = decider.method_name();
  out->gamma = decider.method_options().selection.gamma_fraction;
  out->num_places = layout.num_places();
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
  for (int u = 0; u < layout.num_sets(); ++u) {
    out->set_names.push_back(layout.set(u).name);
    out->set_min_distances.push_back(b.selection.set_stats.at(static_cast<size_t>(u)).min);
  }
  out->selected_sets.clear();
  for (int u : b.selection.selected) out->selected_sets.push_back(layout.set(u).name);
  out->used_sets.clear();
  for (int u : b.used_sets) out->used_sets.push_back(layout.set(u).name);
  out->set_weights.assign(b.set_weights.begin(), b.set_weights.end());
  out->joint_weight = static_cast<float>(b.joint_weight);
  out->off_map_probability = b.off_map_probability;
  out->match_distance = b.match_distance;
  out->missing_sets.clear();
  for (int u : r.missing_sets) out->missing_sets.push_back(layout.set(u).name);
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

bool ToMatchMsg(const Recognition& r, const PlaceLayout& layout, Match* out) {
  out->place_id = r.belief.match;
  out->confidence = r.belief.confidence;
  out->reference_set = r.closest_set >= 0 ? layout.set(r.closest_set).name : "";
  return ToMatchPose(layout.PoseOf(r.belief.match), out);
}

bool ToMatchPose(const std::optional<PlacePose>& pose, Match* out) {
  const bool refused = pose && !PoseProblem(*pose).empty();
  out->has_pose = pose && !refused;
  out->pose = out->has_pose ? ToPoseMsg(*pose) : geometry_msgs::Pose();
  if (!out->has_pose) out->pose.orientation.w = 1;
  return !refused;
}

void ToPoseWithCovarianceMsg(const PoseEstimate& e, geometry_msgs::PoseWithCovariance* out) {
  out->pose = ToPoseMsg(e.mean);
  out->covariance.fill(0.0);
  // Row-major 6 x 6 over (x, y, z, rotation about x, y, z); the estimate is over (x, y, yaw).
  constexpr int kIndex[3] = {0, 1, 5};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out->covariance[6 * kIndex[i] + kIndex[j]] = e.covariance(i, j);
  }
  for (int k : {2, 3, 4}) out->covariance[6 * k + k] = kUnknownVariance;
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

ReferenceSetInfo ToInfoMsg(const StoredReferenceSet& set) { return ToInfoMsg(Summarize(set)); }

ReferenceSetInfo ToInfoMsg(const SetSummary& set) {
  ReferenceSetInfo info;
  info.name = set.layout.name;
  info.condition = set.layout.condition;
  info.descriptor_type = set.layout.descriptor_type;
  info.num_places = set.layout.size();
  info.dimension = set.layout.dimension;
  info.memory_bytes = set.memory_bytes;
  info.storage = set.storage;
  info.shard = set.shard;
  return info;
}

void ToListResponse(const SetList& list, ListReferenceSets::Response* out) {
  for (const SetSummary& s : list.sets) out->sets.push_back(ToInfoMsg(s));
  out->num_places = list.num_places;
  out->calibration = list.calibration;
}

QueryHeader ToQueryHeader(const std_msgs::Header& header) {
  QueryHeader out;
  out.seq = header.seq;
  out.sec = header.stamp.sec;
  out.nsec = header.stamp.nsec;
  out.frame_id = header.frame_id;
  return out;
}

std_msgs::Header ToHeaderMsg(const QueryHeader& header) {
  std_msgs::Header out;
  out.seq = header.seq;
  out.stamp.sec = header.sec;
  out.stamp.nsec = header.nsec;
  out.frame_id = header.frame_id;
  return out;
}

QueryDescriptor ToQueryDescriptor(const Descriptor& msg) {
  QueryDescriptor out;
  out.header = ToQueryHeader(msg.header);
  out.type = msg.descriptor_type;
  out.values = msg.data.data();
  out.size = static_cast<Eigen::Index>(msg.data.size());
  return out;
}

Descriptor ToDescriptorMsg(const QueryDescriptor& descriptor) {
  Descriptor out;
  out.header = ToHeaderMsg(descriptor.header);
  out.descriptor_type = descriptor.type;
  out.data.assign(descriptor.values, descriptor.values + descriptor.size);
  return out;
}

LoadRequest ToLoadRequest(const LoadReferenceSet::Request& msg) {
  return {msg.path, msg.name, msg.condition, msg.shard};
}

LoadReferenceSet::Request ToLoadRequestMsg(const LoadRequest& request) {
  LoadReferenceSet::Request out;
  out.path = request.path;
  out.name = request.name;
  out.condition = request.condition;
  out.shard = request.shard;
  return out;
}

void AddStatus(const StatusValues& values, diagnostic_updater::DiagnosticStatusWrapper& status) {
  for (const auto& [key, value] : values) status.add(key, value);
}

void ToShardDistancesMsg(const ShardAnswer& answer, ShardDistances* out) {
  out->error = answer.error;
  size_t total = 0;
  for (const RowMatrixXf& m : answer.distances) total += static_cast<size_t>(m.size());
  out->distances.reserve(total);
  for (size_t u = 0; u < answer.distances.size(); ++u) {
    const RowMatrixXf& m = answer.distances[u];
    out->set_names.push_back(answer.set_names[u]);
    out->fingerprints.push_back(answer.fingerprints[u]);
    out->counts.push_back(static_cast<int32_t>(m.size()));
    out->distances.insert(out->distances.end(), m.data(), m.data() + m.size());
  }
  if (answer.joint_kind) {
    out->joint_kind = ToString(*answer.joint_kind);
    out->joint_build = answer.joint_build;
    out->joint_sets = answer.joint_sets;
    const RowMatrixXf& j = answer.joint_distances;
    out->joint_distances.assign(j.data(), j.data() + j.size());
  }
}

ShardSet ToShardSetMsg(const StoredReferenceSet& set, uint64_t fingerprint) {
  ShardSet m;
  m.name = set.name();
  m.condition = set.condition();
  m.descriptor_type = set.descriptor_type();
  m.fingerprint = fingerprint;
  m.dimension = set.dimension();
  m.memory_bytes = set.MemoryBytes();
  m.storage = ToString(set.precision());
  m.max_norm = set.size() > 0 ? std::sqrt(static_cast<double>(set.squared_norms().maxCoeff())) : 0;
  m.place_ids.assign(set.place_ids().begin(), set.place_ids().end());
  m.poses.reserve(4 * set.poses().size());
  for (const PlacePose& p : set.poses()) {
    m.poses.insert(m.poses.end(), {p.x_m, p.y_m, p.z_m, p.yaw_rad});
  }
  m.images = set.images();
  m.image_files = set.image_files();
  return m;
}

SetLayout LayoutFromShardSetMsg(const ShardSet& msg) {
  SetLayout set;
  set.name = msg.name;
  set.condition = msg.condition;
  set.descriptor_type = msg.descriptor_type;
  set.place_ids.assign(msg.place_ids.begin(), msg.place_ids.end());
  if (!msg.poses.empty()) {
    if (msg.poses.size() != 4 * msg.place_ids.size()) {
      throw std::invalid_argument("shard set '" + msg.name + "' has " +
                                  std::to_string(msg.poses.size()) + " pose values for " +
                                  std::to_string(msg.place_ids.size()) +
                                  " places (4 per place expected)");
    }
    for (size_t k = 0; k < msg.place_ids.size(); ++k) {
      const double* p = &msg.poses[4 * k];
      set.poses.push_back(PlacePose{p[0], p[1], p[2], p[3]});
    }
  }
  set.images = msg.images;
  set.image_files = msg.image_files;
  set.dimension = msg.dimension;
  return set;
}

ShardSets FromShardInfoMsg(const ShardInfo& msg, const std::string& name) {
  ShardSets out;
  out.name = name;
  out.distance = msg.distance;
  for (const ShardSet& s : msg.sets) {
    out.sets.push_back(ShardSets::Set{LayoutFromShardSetMsg(s), s.fingerprint, s.max_norm});
  }
  return out;
}

ShardAnswer FromShardDistancesMsg(const ShardDistances& msg) {
  ShardAnswer a;
  a.seconds = msg.processing_time;
  if (!msg.error.empty()) {
    a.error = msg.error;
    return a;
  }
  const size_t n = msg.set_names.size();
  a.malformed = msg.fingerprints.size() != n || msg.counts.size() != n;
  size_t offset = 0;
  for (size_t i = 0; !a.malformed && i < n; ++i) {
    const int32_t count = msg.counts[i];
    if (count < 0 || msg.distances.size() - offset < static_cast<size_t>(count)) {
      a.malformed = true;
      break;
    }
    a.distances.push_back(Eigen::Map<const RowMatrixXf>(msg.distances.data() + offset, 1, count));
    offset += static_cast<size_t>(count);
  }
  a.malformed = a.malformed || offset != msg.distances.size();
  if (a.malformed) {
    a.distances.clear();
  } else {
    a.set_names = msg.set_names;
    a.fingerprints = msg.fingerprints;
  }
  if (!msg.joint_kind.empty()) {
    try {
      a.joint_kind = JointKindNames().Parse(msg.joint_kind, "joint_kind");
    } catch (const std::invalid_argument&) {
      // A kind this node does not know: no joint representation it can use.
    }
    a.joint_build = msg.joint_build;
    a.joint_sets = msg.joint_sets;
    a.joint_distances = Eigen::Map<const RowMatrixXf>(
        msg.joint_distances.data(), 1, static_cast<Eigen::Index>(msg.joint_distances.size()));
  }
  return a;
}

}  // namespace bsf_vpr
