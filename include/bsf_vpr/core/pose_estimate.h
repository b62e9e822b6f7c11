// The robot's pose from a belief over places, for a localiser to fuse (robot_localization's
// pose0, amcl's /initialpose): the mean and covariance of the place poses, weighted by the
// posterior over the places that hold its mass.
//
// The covariance is honest about the belief: a belief spread over distant places gives a
// wide covariance, one on a single place the floor (the place's own extent along the route).
// Planar: x, y and yaw; the caller states the rest as unknown.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "bsf_vpr/core/fusion.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

struct PoseEstimateOptions {
  // The places kept are the most probable ones whose posterior adds up to this share.
  double mass = 0.999;
  int max_places = 1000;  // at most this many places enter the estimate
  // Floor of the standard deviation of x and y (metres) and of yaw (radians): a place
  // stands for a stretch of route about one place spacing long.
  double min_std_m = 1.0;
  double min_std_yaw_rad = 0.1;
};

struct PoseEstimate {
  PlacePose mean;
  // Covariance of (x, y, yaw), row-major as in geometry_msgs (x, y, yaw).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int places = 0;  // places that entered the estimate
};

// The pose the belief `belief` puts the robot at, from the place poses `place_poses` (one per
// place, nullopt where a place has none). Bayesian methods without +seq: the posterior's
// weighted mean and covariance over the places that hold `mass` of it. +seq and distance
// methods (`centred_on_match`): the match's pose, with the posterior's spread about it when
// there is a posterior. nullopt when the match has no pose, no weighted place has one, or the
// result is not finite (nothing non-finite is ever returned).
std::optional<PoseEstimate> EstimatePose(const PlaceBelief& belief,
                                         const std::vector<std::optional<PlacePose>>& place_poses,
                                         bool centred_on_match,
                                         const PoseEstimateOptions& options = {});

}  // namespace bsf_vpr
