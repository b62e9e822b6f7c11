// Ground truth and the paper's metrics (Sec. IV-C): precision-recall over a swept
// threshold, its area, recall at 100% precision, and recall@K.
#pragma once

#include <optional>
#include <vector>

#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

// For each query, the places that count as a correct match (sorted; empty when the query
// has no true match in the map).
class GroundTruth {
 public:
  GroundTruth() = default;
  explicit GroundTruth(std::vector<std::vector<int>> correct_places);

  // Frame-aligned traversals: query q shows place q; a match m is correct when
  // |m - q| <= tolerance_frames. Queries q >= num_places have no true match.
  static GroundTruth FromFrameTolerance(int num_queries, int num_places, int tolerance_frames);
  // A match is correct when its place pose lies within tolerance_m metres of the query's
  // pose, by planar distance (x, y: PlanarDistance in place_index.h; height and heading are
  // not compared). place_poses[i] is place i's pose, or nullopt if unknown: a place without
  // a pose is never correct.
  static GroundTruth FromMetricTolerance(const std::vector<PlacePose>& query_poses,
                                         const std::vector<std::optional<PlacePose>>& place_poses,
                                         double tolerance_m);

  int num_queries() const { return static_cast<int>(correct_.size()); }
  const std::vector<int>& CorrectPlaces(int query) const {
    return correct_.at(static_cast<size_t>(query));
  }
  bool HasTrueMatch(int query) const { return !CorrectPlaces(query).empty(); }
  bool IsCorrect(int query, int place) const;
  int NumWithTrueMatch() const;

 private:
  std::vector<std::vector<int>> correct_;
};

// One operating point: the threshold accepts every query with confidence >= threshold.
struct PrPoint {
  double threshold = 0;
  double precision = 1;  // correct accepted / accepted
  double recall = 0;     // correct accepted / queries with a true match
};

// Sweeps the threshold over the distinct confidences, highest first; tied confidences are
// accepted together (one point per distinct value). The curve starts at (recall 0,
// precision 1) with threshold +infinity. `correct[q]` says whether query q's match is right.
std::vector<PrPoint> PrecisionRecallCurve(const std::vector<double>& confidence,
                                          const std::vector<bool>& correct,
                                          int num_with_true_match);
// Trapezoidal area under the curve over recall.
double AreaUnderCurve(const std::vector<PrPoint>& curve);
// The largest recall at which precision is exactly 1 (0 if the first accepted match is wrong).
double RecallAtFullPrecision(const std::vector<PrPoint>& curve);
// Fraction of queries with a true match whose first k ranked places hold a correct one.
double RecallAtK(const std::vector<std::vector<int>>& ranked_places, const GroundTruth& truth,
                 int k);

struct Metrics {
  double auc = 0;
  double recall_at_full_precision = 0;
  double recall_at_1 = 0, recall_at_5 = 0, recall_at_10 = 0;
  int num_queries = 0;
  // Queries without a true match in the map (off it), and how many of them had a match
  // accepted (ScoreOutcomes; ComputeMetrics, which is not told what was accepted, leaves 0).
  int off_map_queries = 0;
  int off_map_accepted = 0;
  std::vector<PrPoint> curve;  // the precision-recall curve the AUC was computed from
};

// All metrics of one method over Q queries. Throws std::invalid_argument if the sizes of
// the inputs disagree with the ground truth.
Metrics ComputeMetrics(const std::vector<int>& matches, const std::vector<double>& confidence,
                       const std::vector<std::vector<int>>& ranked_places,
                       const GroundTruth& truth);

}  // namespace bsf_vpr
