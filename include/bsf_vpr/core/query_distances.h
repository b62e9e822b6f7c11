// One query's distances to the sets of a place layout, set by set in its order, as the
// distance stage gives them: set u is present (1 x N_u distances, row k's at column k) or
// absent (the stage could not give them: the shard of a sharded map that holds the set did
// not answer). The decision (PlaceDecider) runs on the present sets.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

class QueryDistances {
 public:
  QueryDistances() = default;
  explicit QueryDistances(int num_sets) : sets_(static_cast<size_t>(num_sets)) {}  // all absent
  // Every set present: distances[u] for set u.
  static QueryDistances AllPresent(std::vector<RowMatrixXf> distances);

  int num_sets() const { return static_cast<int>(sets_.size()); }
  bool present(int u) const { return sets_.at(static_cast<size_t>(u)).has_value(); }
  // Set u's distances; throws std::logic_error when it is absent.
  const RowMatrixXf& of(int u) const;
  void Set(int u, RowMatrixXf distances) {
    sets_.at(static_cast<size_t>(u)) = std::move(distances);
  }
  // Set u is absent after all (its rows changed under the query).
  void SetAbsent(int u) { sets_.at(static_cast<size_t>(u)).reset(); }
  // Set u's distances moved out (a shard's answer takes them); set u is absent after.
  // Throws std::logic_error when it is absent.
  RowMatrixXf Take(int u);
  // The absent sets, ascending.
  std::vector<int> Absent() const;
  int num_present() const;

  // The query's distances (1 x N, every place in order) to a joint representation of the
  // sets (joint_representation.h), if the map has one for this layout; `build` names the
  // build it came from (a new build: the decision's state starts again).
  struct Joint {
    JointKind kind = JointKind::kDiscriminant;
    uint64_t build = 0;
    RowMatrixXf distances;
  };
  void SetJoint(Joint joint) { joint_ = std::move(joint); }
  const std::optional<Joint>& joint() const { return joint_; }
  std::optional<Joint>& joint() { return joint_; }
  void ClearJoint() { joint_.reset(); }

 private:
  std::vector<std::optional<RowMatrixXf>> sets_;
  std::optional<Joint> joint_;
};

}  // namespace bsf_vpr
