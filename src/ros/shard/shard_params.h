// A fusion shard's parameters (ShardParamsTable()): its map's, its first stage and its
// queue, and the joint representation it serves; nothing of the decision (the combiner's).
#pragma once

#include <ros/node_handle.h>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/methods.h"
#include "src/ros/common/param_util.h"
#include "src/ros/map/map_params.h"

namespace bsf_vpr {

// A fusion shard's parameters: its map's, its first stage and its queue; nothing of the
// decision (the combiner's).
struct ShardParams : MapParams, QueueParams {
  FirstStageOptions first_stage;
  // The joint representation of the shard's sets it builds and serves (the combiner's
  // bsf takes it as its joint hypothesis), and how.
  FusionJoint fusion_joint = FusionJoint::kDiscriminant;
  JointOptions joint;
};

const OptionTable<ShardParams>& ShardParamsTable();
// Reads and validates a shard's parameters as LoadFusionParams does; `shards` (the
// combiner's) is refused by name.
ShardParams LoadShardParams(RosParamSource& source);
ShardParams LoadShardParams(const ros::NodeHandle& pnh);

}  // namespace bsf_vpr
