#pragma once
// A floor or catwalk under or around an end: removed before the axis fit, kept out of the
// refinement near the joint's foot.

#include <Eigen/Core>
#include <vector>

#include "drill_pipe_pose/core/estimator/axis_fit.hpp"

namespace drill_pipe_pose {

/// Removes the points of a support plane (floor, catwalk) from an end's points, as configured in
/// `config` (plane_*): returns the indices of the points kept; all of them when no plane is found.
std::vector<size_t> removeSupportPlane(const std::vector<Eigen::Vector3f>& points,
                                       const EstimatorConfig::AxisFit& config);

/// A level support (floor, catwalk: world +z up, REP 103) under an end whose cylinder-axis fit
/// is `axis` (tool-joint radius `radius` [m]): among the points more than plane_threshold off
/// that cylinder, the horizontal layer 2 plane_threshold thick with the most points, when it
/// holds at least plane_min_fraction of all the points, spreads by a standard deviation of at
/// least plane_min_extent [m] along its narrower horizontal direction, and has most of the other
/// points above it. `height` receives the layer's mean height [m, world z]. False when there is
/// none.
bool findLevelSupport(const std::vector<Eigen::Vector3f>& points, const AxisLine& axis,
                      double radius, const EstimatorConfig::AxisFit& config, float* height);

/// The points of a level support layer among all of `points` (the layer findLevelSupport looks
/// for, without a joint's cylinder to leave out; when the densest layer is not a support, the
/// densest that is, among the four densest) and of its noisy fringe: the indices of those
/// less than 2 plane_threshold above its height, ascending; empty when there is none (or fewer
/// than 30 points).
std::vector<size_t> levelSupportPoints(const std::vector<Eigen::Vector3f>& points,
                                       const EstimatorConfig::AxisFit& config);

}  // namespace drill_pipe_pose
