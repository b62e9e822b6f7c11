#include "bsf_vpr/core/pose_estimate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace bsf_vpr {
namespace {

double WrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

}  // namespace

std::optional<PoseEstimate> EstimatePose(const PlaceBelief& belief,
                                         const std::vector<std::optional<PlacePose>>& place_poses,
                                         bool centred_on_match,
                                         const PoseEstimateOptions& options) {
  const int n = static_cast<int>(place_poses.size());
  if (belief.match < 0 || belief.match >= n) return std::nullopt;
  // The places holding the posterior's mass, most probable first, with their weights.
  std::vector<std::pair<int, double>> weighted;
  const Eigen::VectorXd& log_p = belief.log_posterior;
  if (log_p.size() == n && n > 0) {
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    const int keep = std::min(n, std::max(1, options.max_places));
    // NaN counts as no probability (a strict order for the sort).
    const auto key = [&](int i) {
      return std::isnan(log_p[i]) ? -std::numeric_limits<double>::infinity() : log_p[i];
    };
    std::partial_sort(order.begin(), order.begin() + keep, order.end(),
                      [&](int a, int b) { return key(a) > key(b) || (key(a) == key(b) && a < b); });
    const double top = key(order[0]);
    if (std::isfinite(top)) {
      double total = 0;
      for (int k = 0; k < keep; ++k) {
        const int i = order[k];
        const double w = std::exp(log_p[i] - top);  // relative to the best: no underflow of all
        if (!(w > 0) || !place_poses[i] || !IsFinite(*place_poses[i])) continue;
        weighted.emplace_back(i, w);
        total += std::exp(log_p[i]);
        if (total >= options.mass) break;
      }
    }
  }
  const std::optional<PlacePose>& match_pose = place_poses[belief.match];
  if (centred_on_match && (!match_pose || !IsFinite(*match_pose))) return std::nullopt;
  if (weighted.empty()) {
    if (!match_pose || !IsFinite(*match_pose)) return std::nullopt;
    weighted.emplace_back(belief.match, 1.0);
  }
  double w_sum = 0;
  for (const auto& [i, w] : weighted) w_sum += w;

  PoseEstimate e;
  e.places = static_cast<int>(weighted.size());
  if (centred_on_match) {
    e.mean = *match_pose;
  } else {
    double x = 0, y = 0, z = 0, c = 0, s = 0;
    for (const auto& [i, w] : weighted) {
      const PlacePose& p = *place_poses[i];
      x += w * p.x_m;
      y += w * p.y_m;
      z += w * p.z_m;
      c += w * std::cos(p.yaw_rad);
      s += w * std::sin(p.yaw_rad);
    }
    e.mean.x_m = x / w_sum;
    e.mean.y_m = y / w_sum;
    e.mean.z_m = z / w_sum;
    e.mean.yaw_rad =
        (c == 0 && s == 0) ? place_poses[weighted[0].first]->yaw_rad : std::atan2(s, c);
  }
  // Second moments about the mean (the published pose), so that the covariance covers the
  // belief's spread around it.
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (const auto& [i, w] : weighted) {
    const PlacePose& p = *place_poses[i];
    const Eigen::Vector3d d(p.x_m - e.mean.x_m, p.y_m - e.mean.y_m,
                            WrapAngle(p.yaw_rad - e.mean.yaw_rad));
    m += (w / w_sum) * d * d.transpose();
  }
  m(0, 0) += options.min_std_m * options.min_std_m;
  m(1, 1) += options.min_std_m * options.min_std_m;
  m(2, 2) += options.min_std_yaw_rad * options.min_std_yaw_rad;
  e.covariance = m;
  if (!IsFinite(e.mean) || !m.allFinite()) return std::nullopt;
  return e;
}

}  // namespace bsf_vpr
