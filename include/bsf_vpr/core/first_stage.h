// How the distances from a query to every reference row are computed: exactly, from every
// stored descriptor (ComputeDistances, distances.h), or by the compressed first stage with
// exact re-ranking (ApproximateIndex, approximate_distances.h) for maps too large to search
// exactly at camera rate. LocalMap (the node's, PlaceRecognizer's) and bsf_evaluate go through
// DistanceStage, which chooses the DistanceIndex (distance_index.h) a query is asked of.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/core/approximate_distances.h"
#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/options.h"

namespace bsf_vpr {

// Exact distances from every stored descriptor, or the pca first stage (ApproximateIndex).
enum class FirstStageKind { kExact, kPca };
// Their names (first_stage).
const EnumNames<FirstStageKind>& FirstStageKindNames();
std::string ToString(FirstStageKind kind);

struct FirstStageOptions {
  // The option's text, a name of FirstStageKindNames() (kept as text, as callers write it:
  // kind = "pca"); Kind() parses it, and nothing compares it as a string.
  std::string kind = "exact";
  ApproximateOptions approximate;

  // The kind named; throws std::invalid_argument naming first_stage and the choices.
  FirstStageKind Kind() const;
  void Validate() const;  // throws std::invalid_argument naming the bad field
};

// first_stage, first_stage_dimensions, rerank_candidates, first_stage_sample_rows.
const OptionTable<FirstStageOptions>& FirstStageOptionsTable();

// The distances of a map through the configured first stage. With "pca" the index is built
// from the map on first use (or by Prepare) and rebuilt after Invalidate() or new options.
// Not thread-safe (its owner serialises calls).
class DistanceStage {
 public:
  // Validates; keeps the index when the options it was built with are unchanged.
  void SetOptions(const FirstStageOptions& options);
  const FirstStageOptions& options() const { return options_; }
  FirstStageKind kind() const { return kind_; }  // options().Kind(), parsed by SetOptions
  // The map changed: the index, if any, is rebuilt at the next use.
  void Invalidate() { index_.reset(); }
  // Builds the index now for "pca" (a no-op for "exact" or when it is built).
  void Prepare(const ReferenceSets& map);
  // Q x N_u per set, as ComputeDistances gives them (approximate for "pca" except each set's
  // rerank_candidates smallest per query, which are exact).
  std::vector<RowMatrixXf> Distances(DistanceMetric metric, const RowMatrixXf& queries,
                                     const ReferenceSets& map);
  // The index in use, or null (exact, or not built yet).
  const ApproximateIndex* index() const { return index_.get(); }
  // Takes `index` (built elsewhere, e.g. in the background from a snapshot of the map) as
  // the pca first stage's index; null drops it.
  void Adopt(std::shared_ptr<const ApproximateIndex> index) { index_ = std::move(index); }
  // What a query is asked of now: ExactIndex for "exact"; the pca index, null while none is
  // built or adopted.
  const DistanceIndex* Current() const;
  // One line for logs and diagnostics: "exact", or "pca: 256 dimensions keeping 97.2% of
  // the energy of 1000000 rows, 1000 re-ranked per set, 264.2 MB" (or "pca: no index built
  // yet").
  std::string Summary() const;

 private:
  FirstStageOptions options_;
  FirstStageKind kind_ = FirstStageKind::kExact;
  std::shared_ptr<const ApproximateIndex> index_;
};

}  // namespace bsf_vpr
