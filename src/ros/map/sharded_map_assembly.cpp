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

PlaceLayout ShardedMap::LayoutWith(int k, const ShardInfo& info, DistanceMetric* metric) const {
  // Every shard's info, shard k's replaced by `info`.
  std::vector<const ShardInfo*> infos;
  for (size_t j = 0; j < shards_.size(); ++j) {
    infos.push_back(static_cast<int>(j) == k ? &info : shards_[j].info.get());
  }
  // The distance of the map: that of the shards holding sets (one without sets has its
  // configured or default distance, which does not matter).
  std::string distance;
  PlaceLayout layout;
  layout.SetPlacePoseTolerance(options_.place_pose_tolerance_m);
  for (size_t j = 0; j < infos.size(); ++j) {
    if (!infos[j] || infos[j]->sets.empty()) continue;
    if (distance.empty()) distance = infos[j]->distance;
    if (infos[j]->distance != distance) {
      throw std::invalid_argument("the shards' sets are meant for different distances (" +
                                  distance + ", and " + infos[j]->distance + " on shard " +
                                  shards_[j].name + ")");
    }
    for (const ShardSet& s : infos[j]->sets) {
      if (const std::string bad = SetNameProblem(s.name); !bad.empty()) {
        throw std::invalid_argument("shard " + shards_[j].name + " holds a set " + bad);
      }
      if (layout.IndexOf(s.name) >= 0) {
        throw std::invalid_argument("set '" + s.name + "' is held by two shards");
      }
      if (layout.dimension() != 0 && s.dimension != layout.dimension()) {
        throw std::invalid_argument("set '" + s.name + "' has dimension " +
                                    std::to_string(s.dimension) + ", the map " +
                                    std::to_string(layout.dimension()));
      }
      layout.Add(LayoutFromShardSetMsg(s));
    }
  }
  *metric = ParseDistanceMetric(distance.empty() ? info.distance : distance);
  if (layout.num_sets() > 0 && options_.metric && *metric != *options_.metric) {
    throw std::invalid_argument("the shards use " + ToString(*metric) + " distance, this node " +
                                ToString(*options_.metric));
  }
  return layout;
}

MapBackend::Query ShardedMap::Assemble(const QueryHeader& header, double query_norm,
                                       const std::vector<const ShardDistances*>& answers) {
  Query query;
  query.header = header;
  query.layout = layout_;
  query.distances = QueryDistances(layout_->num_sets());
  std::string refusals;  // of the shards that refused the descriptor
  bool any = false;      // a shard's distances are in
  int u = 0;             // the layout's index of the shard's first set
  for (size_t k = 0; k < shards_.size(); ++k) {
    Shard& shard = shards_[k];
    if (!shard.info) {
      query.missing_shards.push_back(shard.name);  // no sets known yet
      continue;
    }
    const ShardDistances* a = answers.at(k);
    const std::vector<ShardSet>& sets = shard.info->sets;
    if (a && !a->error.empty() && !sets.empty()) {
      refusals += (refusals.empty() ? "" : "; ") + ("shard " + shard.name + ": " + a->error);
    }
    // An answer for other sets than the layout's (a shard whose new shard_info has not
    // arrived, or was refused), a refusal, or a malformed one counts as none.
    bool usable = a && a->error.empty() && a->set_names.size() == sets.size() &&
                  a->fingerprints.size() == sets.size() && a->counts.size() == sets.size();
    size_t total = 0;
    for (size_t i = 0; usable && i < sets.size(); ++i) {
      usable = a->set_names[i] == sets[i].name && a->fingerprints[i] == sets[i].fingerprint &&
               a->counts[i] == static_cast<int32_t>(sets[i].place_ids.size());
      total += sets[i].place_ids.size();
    }
    usable = usable && a->distances.size() == total;
    // Distances no exact distance can be (a broken kernel, a corrupted message): that
    // shard's fault, not the query's.
    for (size_t i = 0, offset = 0; usable && i < sets.size();
         offset += sets[i].place_ids.size(), ++i) {
      const std::string problem =
          ShardDistancesProblem(a->distances.data() + offset, sets[i].place_ids.size(),
                                metric_ == DistanceMetric::kCosine, query_norm, sets[i].max_norm);
      if (problem.empty()) continue;
      usable = false;
      ++shard.invalid_answers;
      shard.invalid = "set '" + sets[i].name + "': " + problem;
      ROS_WARN_THROTTLE(5.0,
                        "bsf_vpr: shard %s answered distances that cannot be exact (%s): "
                        "deciding without its sets for that query",
                        shard.name.c_str(), shard.invalid.c_str());
    }
    if (!usable) {
      if (!sets.empty()) query.missing_shards.push_back(shard.name);
      u += static_cast<int>(sets.size());  // absent
      continue;
    }
    any = any || !sets.empty();
    query.seconds = std::max(query.seconds, a->processing_time);
    size_t offset = 0;
    for (size_t i = 0; i < sets.size(); ++i, ++u) {
      const Eigen::Index n = a->counts[i];
      query.distances.Set(u, Eigen::Map<const RowMatrixXf>(a->distances.data() + offset, 1, n));
      offset += static_cast<size_t>(n);
    }
  }
  // A descriptor every shard with distances refused is refused (its dimension, a NaN: the
  // same reason on each); one shard's refusal alone makes that shard missing.
  if (!any && !refusals.empty()) throw std::invalid_argument(refusals);
  AttachJoint(answers, &query);
  return query;
}

void ShardedMap::AttachJoint(const std::vector<const ShardDistances*>& answers, Query* query) {
  joint_used_.clear();
  if (!joint_kind_) return;
  const std::string kind = ToString(*joint_kind_);
  const int places = layout_->num_places();
  // Of the shards' joint representations of the kind asked for, over every place of the
  // layout, finite and not negative, the one built from the most sets of the layout.
  const ShardDistances* best = nullptr;
  size_t best_k = 0;
  for (size_t k = 0; k < answers.size(); ++k) {
    const ShardDistances* a = answers[k];
    if (!a || !a->error.empty() || a->joint_kind != kind || a->joint_sets.size() < 2 ||
        a->joint_distances.size() != static_cast<size_t>(places)) {
      continue;
    }
    bool fits = true;
    for (const std::string& name : a->joint_sets) fits = fits && layout_->IndexOf(name) >= 0;
    for (float v : a->joint_distances) fits = fits && v >= 0 && v <= 3.0f;  // within [0, 2]
    if (fits && (!best || a->joint_sets.size() > best->joint_sets.size())) {
      best = a;
      best_k = k;
    }
  }
  if (!best) return;
  // The build names the shard too: another shard's, or its next, starts the state again.
  QueryDistances::Joint joint;
  joint.kind = *joint_kind_;
  joint.build = (static_cast<uint64_t>(best_k + 1) << 48) ^ best->joint_build;
  joint.distances = Eigen::Map<const RowMatrixXf>(best->joint_distances.data(), 1, places);
  query->distances.SetJoint(std::move(joint));
  joint_used_ = shards_[best_k].name + " (" + std::to_string(best->joint_sets.size()) + " sets)";
}

}  // namespace bsf_vpr
