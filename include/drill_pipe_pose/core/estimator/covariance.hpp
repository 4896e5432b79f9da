#pragma once
// The reported uncertainty of an end's pose: the profile fit's covariance in the world, with the
// configured floors, and the rig calibration's share (EstimatorConfig::Covariance).

#include <Eigen/Core>
#include <cstddef>

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/profile_registration.hpp"

namespace drill_pipe_pose {

/// 6x6 world covariance (x y z [m], rotation about world x y z [rad]) of a 5-DoF profile fit,
/// inflated by c.inflation, with the floors c.min_lateral_std, c.min_axial_std, c.min_tilt_std and
/// c.roll_variance about the axis (roll is unobservable).
Eigen::Matrix<double, 6, 6> worldCovariance(const ProfileFitResult& fit,
                                            const EstimatorConfig::Covariance& c);

/// The rig calibration's share of an end's covariance (c.extrinsic_*) for an end on axis `z`
/// fitted to the points of `n` cameras at a mean `range` [m], its inliers spanning `length` [m]
/// along the axis: each camera's extrinsic error moves its points by t^2 + (rotation range)^2 in
/// each direction and tilts the axis by rotation^2 + (t / length)^2 (two cameras' points offset
/// against each other across the joint's length); n cameras average them. A bias for a fixed
/// rig: it is added after the temporal filter, which cannot reduce it.
Eigen::Matrix<double, 6, 6> calibrationCovariance(const Eigen::Vector3d& z, size_t n, double range,
                                                  double length,
                                                  const EstimatorConfig::Covariance& c);

/// Reported standard deviation [m] of a fit's position along its axis (worldCovariance).
double axialStd(const ProfileFitResult& fit, const EstimatorConfig::Covariance& c);

}  // namespace drill_pipe_pose
