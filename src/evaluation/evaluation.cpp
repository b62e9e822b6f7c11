#include "bsf_vpr/evaluation/evaluation.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "bsf_vpr/core/place_index.h"

namespace bsf_vpr {

GroundTruth::GroundTruth(std::vector<std::vector<int>> correct_places)
    : correct_(std::move(correct_places)) {
  for (auto& c : correct_) {
    std::sort(c.begin(), c.end());
    c.erase(std::unique(c.begin(), c.end()), c.end());
  }
}

GroundTruth GroundTruth::FromFrameTolerance(int num_queries, int num_places, int tolerance_frames) {
  if (tolerance_frames < 0) {
    throw std::invalid_argument("tolerance_frames must be >= 0, got " +
                                std::to_string(tolerance_frames));
  }
  std::vector<std::vector<int>> correct(static_cast<size_t>(num_queries));
  for (int q = 0; q < num_queries && q < num_places; ++q) {
    for (int p = std::max(0, q - tolerance_frames);
         p <= std::min(num_places - 1, q + tolerance_frames); ++p) {
      correct[static_cast<size_t>(q)].push_back(p);
    }
  }
  return GroundTruth(std::move(correct));
}

GroundTruth GroundTruth::FromMetricTolerance(
    const std::vector<PlacePose>& query_poses,
    const std::vector<std::optional<PlacePose>>& place_poses, double tolerance_m) {
  if (!(tolerance_m >= 0)) throw std::invalid_argument("tolerance_m must be >= 0");
  std::vector<std::vector<int>> correct(query_poses.size());
  for (size_t q = 0; q < query_poses.size(); ++q) {
    const PlacePose& a = query_poses[q];
    for (size_t p = 0; p < place_poses.size(); ++p) {
      if (!place_poses[p]) continue;
      if (PlanarDistance(a, *place_poses[p]) <= tolerance_m) {
        correct[q].push_back(static_cast<int>(p));
      }
    }
  }
  return GroundTruth(std::move(correct));
}

bool GroundTruth::IsCorrect(int query, int place) const {
  const std::vector<int>& c = CorrectPlaces(query);
  return std::binary_search(c.begin(), c.end(), place);
}

int GroundTruth::NumWithTrueMatch() const {
  return static_cast<int>(std::count_if(correct_.begin(), correct_.end(),
                                        [](const std::vector<int>& c) { return !c.empty(); }));
}

std::vector<PrPoint> PrecisionRecallCurve(const std::vector<double>& confidence,
                                          const std::vector<bool>& correct,
                                          int num_with_true_match) {
  if (confidence.size() != correct.size()) {
    throw std::invalid_argument("precision-recall needs one correctness flag per confidence");
  }
  std::vector<size_t> order(confidence.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return confidence[a] > confidence[b]; });
  std::vector<PrPoint> curve{{INFINITY, 1.0, 0.0}};
  size_t accepted = 0, true_pos = 0;
  for (size_t i = 0; i < order.size();) {
    const double c = confidence[order[i]];
    while (i < order.size() && confidence[order[i]] == c) {
      ++accepted;
      true_pos += correct[order[i]] ? 1 : 0;
      ++i;
    }
    PrPoint p;
    p.threshold = c;
    p.precision = static_cast<double>(true_pos) / static_cast<double>(accepted);
    p.recall = num_with_true_match > 0 ? static_cast<double>(true_pos) / num_with_true_match : 0.0;
    curve.push_back(p);
  }
  return curve;
}

double AreaUnderCurve(const std::vector<PrPoint>& curve) {
  double area = 0;
  for (size_t i = 1; i < curve.size(); ++i) {
    area += (curve[i].recall - curve[i - 1].recall) * 0.5 *
            (curve[i].precision + curve[i - 1].precision);
  }
  return area;
}

double RecallAtFullPrecision(const std::vector<PrPoint>& curve) {
  double best = 0;
  for (size_t i = 1; i < curve.size(); ++i) {
    if (curve[i].precision == 1.0) best = std::max(best, curve[i].recall);
  }
  return best;
}

double RecallAtK(const std::vector<std::vector<int>>& ranked_places, const GroundTruth& truth,
                 int k) {
  const int denom = truth.NumWithTrueMatch();
  if (denom == 0) return 0;
  int hits = 0;
  for (int q = 0; q < truth.num_queries(); ++q) {
    const std::vector<int>& ranked = ranked_places.at(static_cast<size_t>(q));
    const size_t n = std::min(ranked.size(), static_cast<size_t>(k));
    for (size_t j = 0; j < n; ++j) {
      if (truth.IsCorrect(q, ranked[j])) {
        ++hits;
        break;
      }
    }
  }
  return static_cast<double>(hits) / denom;
}

Metrics ComputeMetrics(const std::vector<int>& matches, const std::vector<double>& confidence,
                       const std::vector<std::vector<int>>& ranked_places,
                       const GroundTruth& truth) {
  const size_t q = static_cast<size_t>(truth.num_queries());
  if (matches.size() != q || confidence.size() != q || ranked_places.size() != q) {
    throw std::invalid_argument("metrics: " + std::to_string(matches.size()) +
                                " results for a ground truth of " + std::to_string(q) + " queries");
  }
  std::vector<bool> correct(q);
  for (size_t i = 0; i < q; ++i) correct[i] = truth.IsCorrect(static_cast<int>(i), matches[i]);
  const std::vector<PrPoint> curve =
      PrecisionRecallCurve(confidence, correct, truth.NumWithTrueMatch());
  Metrics m;
  m.auc = AreaUnderCurve(curve);
  m.recall_at_full_precision = RecallAtFullPrecision(curve);
  m.recall_at_1 = RecallAtK(ranked_places, truth, 1);
  m.recall_at_5 = RecallAtK(ranked_places, truth, 5);
  m.recall_at_10 = RecallAtK(ranked_places, truth, 10);
  m.num_queries = static_cast<int>(q);
  m.off_map_queries = m.num_queries - truth.NumWithTrueMatch();
  m.curve = curve;
  return m;
}

}  // namespace bsf_vpr
