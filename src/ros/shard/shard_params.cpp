#include "src/ros/shard/shard_params.h"

#include <stdexcept>

namespace bsf_vpr {

const OptionTable<ShardParams>& ShardParamsTable() {
  static const OptionTable<ShardParams> kTable =
      OptionTable<ShardParams>()
          .Include(MapParamsTable(), AsBase<MapParams>())
          .Include(
              FirstStageOptionsTable(), [](auto& p) -> auto& { return p.first_stage; })
          .Include(QueueParamsTable(), AsBase<QueueParams>())
          .AddChoice(
              "fusion_joint", [](auto& p) -> auto& { return p.fusion_joint; },
              "the joint representation of this shard's sets (two or more that share places) "
              "it builds in the background and serves with its distances, for the combiner's "
              "bsf: discriminant, mean_descriptor, subspace or none",
              FusionJointNames())
          .Include(
              JointOptionsTable(), [](auto& p) -> auto& { return p.joint; });
  return kTable;
}

ShardParams LoadShardParams(const ros::NodeHandle& pnh) {
  RosParamSource source = RosParamSource::FromNodeHandle(pnh);
  return LoadShardParams(source);
}

ShardParams LoadShardParams(RosParamSource& source) {
  if (source.Has("shards")) {
    throw std::invalid_argument(
        "a fusion shard holds sets; the parameter shards is the combiner's (a fusion node)");
  }
  ShardParams p = LoadOptions(ShardParamsTable(), source);
  p.reference_sets = LoadReferenceSetEntries(source);
  source.RefuseUnread();
  p.first_stage.Validate();
  return p;
}

}  // namespace bsf_vpr
