#include "bsf_vpr/core/pose_estimate.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "bsf_vpr/core/place_index.h"

namespace bsf_vpr {
namespace {

double WrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// (x, y, yaw) of `p` less `mean`, yaw wrapped.
Eigen::Vector3d Offset(const PlacePose& p, const PlacePose& mean) {
  return Eigen::Vector3d(p.x_m - mean.x_m, p.y_m - mean.y_m, WrapAngle(p.yaw_rad - mean.yaw_rad));
}

// What EstimatePose reads of the belief and the places' poses.
struct Places {
  const PlaceBelief& belief;
  const std::vector<std::optional<PlacePose>>& poses;
  const PlacePose& match_pose;
  double neighbourhood_m;
  bool has_posterior;  // the posterior given "on the map" (a NaN one counts as none)

  int size() const { return static_cast<int>(poses.size()); }
  const PlacePose& pose(int i) const { return *poses[static_cast<size_t>(i)]; }
  bool Posed(int i) const {
    return poses[static_cast<size_t>(i)] && IsFinite(*poses[static_cast<size_t>(i)]);
  }
  bool Near(int i) const {
    return i == belief.match || PlanarDistance(pose(i), match_pose) <= neighbourhood_m;
  }
  double Weight(int i) const { return has_posterior ? std::exp(belief.log_posterior(i)) : 0.0; }
};

// The second moment about `mean` of the neighbourhood's places, weighted by their posterior
// normalised by m_near: where the robot is, given that the neighbourhood holds it.
Eigen::Matrix3d NearSecondMoment(const Places& places, const PlacePose& mean, double m_near) {
  Eigen::Matrix3d in_near = Eigen::Matrix3d::Zero();
  for (int i = 0; i < places.size(); ++i) {
    if (!places.Posed(i) || !places.Near(i)) continue;
    const double w = places.Weight(i);
    if (!(w > 0)) continue;
    const Eigen::Vector3d d = Offset(places.pose(i), mean);
    in_near += (w / m_near) * d * d.transpose();
  }
  return in_near;
}

}  // namespace

std::optional<PoseEstimate> EstimatePose(const PlaceBelief& belief,
                                         const std::vector<std::optional<PlacePose>>& place_poses,
                                         bool centred_on_match,
                                         const PoseEstimateOptions& options) {
  const int n = static_cast<int>(place_poses.size());
  if (belief.match < 0 || belief.match >= n) return std::nullopt;
  const std::optional<PlacePose>& match_pose = place_poses[static_cast<size_t>(belief.match)];
  if (!match_pose || !IsFinite(*match_pose)) return std::nullopt;
  const Eigen::VectorXd& log_p = belief.log_posterior;
  const Places places{
      belief, place_poses, *match_pose, options.neighbourhood_m,
      log_p.size() == n && n > 0 && !log_p.hasNaN() && std::isfinite(log_p.maxCoeff())};
  double m_near = 0;
  int near_places = 0;
  double x = 0, y = 0, z = 0, c = 0, s = 0;
  for (int i = 0; i < n; ++i) {
    if (!places.Posed(i) || !places.Near(i)) continue;
    const double w = places.Weight(i);
    if (!(w > 0) && i != belief.match) continue;
    const PlacePose& p = places.pose(i);
    m_near += w;
    ++near_places;
    x += w * p.x_m;
    y += w * p.y_m;
    z += w * p.z_m;
    c += w * std::cos(p.yaw_rad);
    s += w * std::sin(p.yaw_rad);
  }
  PoseEstimate e;
  e.places = near_places;
  if (centred_on_match || !(m_near > 0)) {
    e.mean = *match_pose;
  } else {
    e.mean.x_m = x / m_near;
    e.mean.y_m = y / m_near;
    e.mean.z_m = z / m_near;
    e.mean.yaw_rad = (c == 0 && s == 0) ? match_pose->yaw_rad : std::atan2(s, c);
  }
  // A P(off) that is not a number says nothing of where the robot is: all of it may be wrong.
  const double p_on = std::isfinite(belief.off_map_probability)
                          ? 1 - std::clamp(belief.off_map_probability, 0.0, 1.0)
                          : 0.0;
  Eigen::Matrix3d floor = Eigen::Matrix3d::Zero();
  floor(0, 0) = floor(1, 1) = options.min_std_m * options.min_std_m;
  floor(2, 2) = options.min_std_yaw_rad * options.min_std_yaw_rad;
  // Given that the robot is in the neighbourhood: its spread there, plus the place's own
  // extent (the floor). A distance method has no posterior: the match alone, the floor.
  const Eigen::Matrix3d in_near = places.has_posterior && m_near > 0
                                      ? NearSecondMoment(places, e.mean, m_near)
                                      : Eigen::Matrix3d::Zero();
  e.covariance = in_near + floor;
  // That it is not: off the map, or at a far place (or one without a pose).
  e.wrong_probability = places.has_posterior ? 1 - p_on * std::min(1.0, m_near) : 1 - p_on;
  if (!IsFinite(e.mean) || !e.covariance.allFinite()) return std::nullopt;
  return e;
}

}  // namespace bsf_vpr
