// Conversions between bsf_vpr messages and core types. No copies of descriptor data where a
// view will do.
#pragma once

#include <bsf_vpr/Belief.h>
#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/ListReferenceSets.h>
#include <bsf_vpr/LoadReferenceSet.h>
#include <bsf_vpr/Match.h>
#include <bsf_vpr/ReferenceSetInfo.h>
#include <bsf_vpr/ShardDistances.h>
#include <bsf_vpr/ShardInfo.h>
#include <bsf_vpr/ShardSet.h>
#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseWithCovariance.h>
#include <geometry_msgs/TransformStamped.h>

#include <Eigen/Core>
#include <string>

#include "bsf_vpr/core/place_decider.h"
#include "bsf_vpr/core/pose_estimate.h"
#include "bsf_vpr/map/local_map.h"
#include "bsf_vpr/map/shard_assembly.h"
#include "bsf_vpr/map/map_backend.h"

namespace bsf_vpr {

// A read-only view on the message's data (valid while the message lives).
inline Eigen::Map<const Eigen::VectorXf> DescriptorView(const Descriptor& msg) {
  return Eigen::Map<const Eigen::VectorXf>(msg.data.data(),
                                           static_cast<Eigen::Index>(msg.data.size()));
}

// The map's plain types (map_backend.h) and the messages: converted here, at the ROS edge.
QueryHeader ToQueryHeader(const std_msgs::Header& header);
std_msgs::Header ToHeaderMsg(const QueryHeader& header);
// A view on the message (valid while it lives).
QueryDescriptor ToQueryDescriptor(const Descriptor& msg);
Descriptor ToDescriptorMsg(const QueryDescriptor& descriptor);
LoadRequest ToLoadRequest(const LoadReferenceSet::Request& msg);
LoadReferenceSet::Request ToLoadRequestMsg(const LoadRequest& request);
ReferenceSetInfo ToInfoMsg(const SetSummary& set);
void ToListResponse(const SetList& list, ListReferenceSets::Response* out);
void AddStatus(const StatusValues& values, diagnostic_updater::DiagnosticStatusWrapper& status);
// A shard's answer (header and shard name left to the caller).
void ToShardDistancesMsg(const ShardAnswer& answer, ShardDistances* out);

// Fills `out` (header left to the caller) from a recognition. belief_top_k 0 lists every
// place; otherwise the K most probable, best first.
// `decider` found `r` on `layout`.
void ToBeliefMsg(const Recognition& r, const PlaceLayout& layout, const PlaceDecider& decider,
                 int belief_top_k, Belief* out);

// Fills `out` (header left to the caller) for the match of `r`, its pose by ToMatchPose
// from the layout's pose of the matched place; returns what ToMatchPose returns.
bool ToMatchMsg(const Recognition& r, const PlaceLayout& layout, Match* out);
// Fills out->has_pose and out->pose from the matched place's pose `pose`: has_pose false and
// the identity pose without one, or with one that PoseProblem refuses (place_layout.h). The
// sets' checks keep such poses out of a layout; this is the last guard before /match and
// tf, which must never carry NaN. Returns false for a refused pose, for the caller to report.
bool ToMatchPose(const std::optional<PlacePose>& pose, Match* out);

geometry_msgs::Pose ToPoseMsg(const PlacePose& pose);

// The pose and its covariance, as a localiser takes them: x, y and yaw from the estimate,
// z, roll and pitch stated as unknown (variance kUnknownVariance).
constexpr double kUnknownVariance = 1e6;
void ToPoseWithCovarianceMsg(const PoseEstimate& estimate, geometry_msgs::PoseWithCovariance* out);

// The transform from the match's frame (its header's frame_id) to `place_frame` at the
// matched place's pose, stamped `stamp`. Meaningful only for a match with has_pose.
geometry_msgs::TransformStamped ToPlaceTransformMsg(const Match& match, const ros::Time& stamp,
                                                    const std::string& place_frame);

ReferenceSetInfo ToInfoMsg(const StoredReferenceSet& set);

// A shard's set for the combiner: its layout and fingerprint (SetFingerprint), no rows.
ShardSet ToShardSetMsg(const StoredReferenceSet& set, uint64_t fingerprint);
// The set's layout as the combiner holds it (no descriptors). Throws std::invalid_argument
// naming the set when its poses are not 4 per place.
SetLayout LayoutFromShardSetMsg(const ShardSet& msg);
// What the shard `name` (as the map knows it: resolved) holds, from its shard_info. Throws
// std::invalid_argument as LayoutFromShardSetMsg does.
ShardSets FromShardInfoMsg(const ShardInfo& msg, const std::string& name);
// A shard's answer from its distances message: `malformed` (its sets' distances left out)
// when the sets' names, fingerprints and counts disagree in number, or the counts with the
// distances. A refusal keeps only its error.
ShardAnswer FromShardDistancesMsg(const ShardDistances& msg);

}  // namespace bsf_vpr
