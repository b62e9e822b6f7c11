// Basic types shared by the core: descriptor matrices and place poses.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace bsf_vpr {

// Descriptors and distance matrices are stored one row per item (row-major), so a row is a
// contiguous float array: one descriptor, or one query's distances to all places of a set.
using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Pose of a place in the map frame: metres and radians.
struct PlacePose {
  double x_m = 0, y_m = 0, z_m = 0, yaw_rad = 0;
};

// No NaN or infinity in any field.
inline bool IsFinite(const PlacePose& p) {
  return std::isfinite(p.x_m) && std::isfinite(p.y_m) && std::isfinite(p.z_m) &&
         std::isfinite(p.yaw_rad);
}

}  // namespace bsf_vpr
