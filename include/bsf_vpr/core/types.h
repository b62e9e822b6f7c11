// Basic matrix types shared by the core.
#pragma once

#include <Eigen/Core>

namespace bsf_vpr {

// Descriptors and distance matrices are stored one row per item (row-major), so a row is a
// contiguous float array: one descriptor, or one query's distances to all places of a set.
using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

}  // namespace bsf_vpr
