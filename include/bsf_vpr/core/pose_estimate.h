// The robot's pose from a belief over places, for a localiser to fuse (robot_localization's
// pose0, amcl's /initialpose): where the accepted match says the robot is, with a covariance
// that says how far it may be off (docs/ros.md, "A pose for the robot's localiser").
//
// The mean is the posterior's mean over the match's neighbourhood (the places within
// neighbourhood_m of it), not over the whole map: the tails of a belief with several modes
// would pull it where the robot is not. The covariance is where the robot is given that the
// neighbourhood holds it: the second moment, about that mean, of the neighbourhood's posterior
// (normalised to its mass m_near), plus the place's own extent (the floor). The chance that
// the neighbourhood does not hold it, 1 - (1 - P(off)) m_near (off the map, or at a far
// place), is wrong_probability, carried by the acceptance rule and said beside the pose, not
// folded into the covariance: the training-free posterior keeps a few per cent on far places
// even when the match is right, and folded in they made sigma tens of metres for errors of a
// few (mean NEES 0.02 on a live drive). A localiser that weighs the pose by its Mahalanobis
// distance (a consistency test, NEES) then sees errors of the size it claims whenever the
// match is right, and rejects a wrong one as an outlier (pose0_rejection_threshold).
// Planar: x, y and yaw; the caller states the rest as unknown.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "bsf_vpr/core/fusion.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

struct PoseEstimateOptions {
  // The match's neighbourhood: places within this planar distance (metres) of the match's
  // pose; 0: the match alone.
  double neighbourhood_m = 0;
  // Floor of the standard deviation of x and y (metres) and of yaw (radians): a place stands
  // for a stretch of route about one place spacing long.
  double min_std_m = 1.0;
  double min_std_yaw_rad = 0.1;
};

struct PoseEstimate {
  PlacePose mean;
  // Covariance of (x, y, yaw), row-major as in geometry_msgs (x, y, yaw).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int places = 0;  // places of the neighbourhood that entered the mean
  // That the robot is not in the neighbourhood (not in the covariance): 1 - (1 - P(off))
  // m_near; a distance method, without a posterior, P(off) alone (0 without off_map); 1
  // where P(off) is not a number.
  double wrong_probability = 0;
};

// The pose the belief `belief` puts the robot at, from the place poses `place_poses` (one per
// place, nullopt where a place has none). Bayesian methods without +seq: the neighbourhood's
// posterior mean, as above. +seq and distance methods (`centred_on_match`): the match's pose,
// with the same covariance about it where there is a posterior (distance methods: the floor).
// belief.off_map_probability is P(off). nullopt when the match has no pose, or the result is
// not finite (nothing non-finite is ever returned).
std::optional<PoseEstimate> EstimatePose(const PlaceBelief& belief,
                                         const std::vector<std::optional<PlacePose>>& place_poses,
                                         bool centred_on_match,
                                         const PoseEstimateOptions& options = {});

}  // namespace bsf_vpr
