#pragma once
// Stage "axis fit": the robust known-radius cylinder axis of an end's points [m, world].

#include <Eigen/Core>
#include <vector>

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"

namespace drill_pipe_pose {

/// An infinite line: a point on it and a unit direction (sign arbitrary).
struct AxisLine {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

/// Result of the robust known-radius cylinder fit.
struct AxisFitResult {
  bool ok = false;
  AxisLine axis;
  size_t inliers = 0;
  double rms = 0.0;  ///< [m] RMS of |distance to axis - radius| over inliers
};

/// Robust cylinder-axis fit with a known radius [m]: global-PCA and local-PCA (RANSAC) hypotheses,
/// each refined by Gauss-Newton with Tukey weights, best truncated cost wins.
AxisFitResult fitCylinderAxis(const std::vector<Eigen::Vector3f>& points, double radius,
                              const EstimatorConfig::AxisFit& config);

}  // namespace drill_pipe_pose
