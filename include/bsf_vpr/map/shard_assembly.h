// A sharded map's work on plain types (ShardedMap in src/ros/map/ converts its messages and
// keeps the counts): one place layout from the sets every shard holds, and one query's
// distances from the shards' answers (docs/architecture.md, "The sharded protocol").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/query_distances.h"
#include "bsf_vpr/map/local_map.h"

namespace bsf_vpr {

// What one shard holds, as its shard_info says.
struct ShardSets {
  std::string name;      // the shard's
  std::string distance;  // the distance its sets' distances are: euclidean | cosine
  struct Set {
    SetLayout layout;
    uint64_t fingerprint = 0;  // SetFingerprint: changes with its rows, places or precision
    double max_norm = 0;       // the largest L2 norm of its rows (bounds a distance)
  };
  std::vector<Set> sets;
};

struct MergedLayout {
  PlaceLayout layout;
  DistanceMetric metric = DistanceMetric::kEuclidean;
};

// One layout from every shard's sets, in the order of `shards` and each shard's own (null:
// the shard's sets are not known yet). The distance is that of the shards holding sets
// (`fallback` when none holds one). Throws std::invalid_argument naming the fault: sets for
// different distances, a name refused or held twice, another dimension, poses that
// contradict the layout's beyond `pose_tolerance_m`, or a distance other than `configured`.
MergedLayout MergeShardLayouts(const std::vector<const ShardSets*>& shards,
                               const std::string& fallback,
                               std::optional<DistanceMetric> configured, double pose_tolerance_m);

// One query's distances, set by set of `layout` (merged from `shards`, null where a shard's
// sets are not known yet), from the shards' answers (nullopt: none), whose distances move
// into it.
struct AssembledQuery {
  QueryDistances distances;
  std::vector<std::string> missing_shards;  // shards whose sets are absent from it
  double seconds = 0;                       // the slowest shard's time
  // Per shard: why its distances could not be exact (ShardDistancesProblem), "" if they can.
  std::vector<std::string> impossible;
  std::string joint_from;  // the shard whose joint representation is attached ("" if none)
};
// A shard's answer counts only when it is well formed, for the sets the layout has of it
// (names, fingerprints, counts) and its distances can be exact for a query of L2 norm `query_norm`;
// otherwise its sets are absent. The joint representation of `joint` attached is the one
// over every place of the layout, of sets of the layout, built from the most sets. Throws
// std::invalid_argument with the refusals when every shard holding sets refused the
// descriptor (its dimension, a NaN: the same reason on each).
AssembledQuery AssembleShardAnswers(const PlaceLayout& layout,
                                    const std::vector<std::string>& names,
                                    const std::vector<const ShardSets*>& shards,
                                    std::vector<std::optional<ShardAnswer>> answers,
                                    DistanceMetric metric, double query_norm,
                                    std::optional<JointKind> joint);

}  // namespace bsf_vpr
