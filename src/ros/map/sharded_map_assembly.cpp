#include "src/ros/map/sharded_map.h"

// ShardedMap: the layout from the shards' infos, and a query from the shards' answers.

#include <bsf_vpr/GetShardDistances.h>
#include <bsf_vpr/GetShardInfo.h>
#include <bsf_vpr/UnloadReferenceSet.h>

#include <algorithm>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/set_loading.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/map/sharded_map_parts.h"

namespace bsf_vpr {

using namespace sharded;

MergedLayout ShardedMap::LayoutWith(int k, const ShardSets& sets) const {
  std::vector<const ShardSets*> all;
  for (size_t j = 0; j < shards_.size(); ++j) {
    all.push_back(static_cast<int>(j) == k ? &sets : shards_[j].sets.get());
  }
  return MergeShardLayouts(all, sets.distance, options_.metric, options_.place_pose_tolerance_m);
}

MapBackend::Query ShardedMap::Assemble(const QueryHeader& header, double query_norm,
                                       const std::vector<const ShardDistances*>& answers) {
  std::vector<std::string> names;
  std::vector<const ShardSets*> sets;
  std::vector<std::optional<ShardAnswer>> given(answers.size());
  for (size_t k = 0; k < shards_.size(); ++k) {
    names.push_back(shards_[k].name);
    sets.push_back(shards_[k].sets.get());
    if (answers.at(k)) given[k] = FromShardDistancesMsg(*answers[k]);
  }
  AssembledQuery assembled = AssembleShardAnswers(*layout_, names, sets, std::move(given), metric_,
                                                  query_norm, joint_kind_);
  for (size_t k = 0; k < shards_.size(); ++k) {
    if (assembled.impossible[k].empty()) continue;
    Shard& shard = shards_[k];
    ++shard.invalid_answers;
    shard.invalid = assembled.impossible[k];
    ROS_WARN_THROTTLE(5.0,
                      "bsf_vpr: shard %s answered distances that cannot be exact (%s): "
                      "deciding without its sets for that query",
                      shard.name.c_str(), shard.invalid.c_str());
  }
  joint_used_ = assembled.joint_from;
  Query query;
  query.header = header;
  query.layout = layout_;
  query.distances = std::move(assembled.distances);
  query.missing_shards = std::move(assembled.missing_shards);
  query.seconds = assembled.seconds;
  return query;
}

}  // namespace bsf_vpr
