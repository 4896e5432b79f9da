#pragma once
// Error metrics (docs/conventions.md, "Error metrics"), shared by the evaluator, the bench and the
// tests. Roll about the pipe axis is never scored.

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace drill_pipe_pose {

/// Error of one estimated pipe-end pose against the truth (both T_world_end).
struct PoseError {
  Eigen::Vector3d position;  ///< estimated minus true origin, world frame [m]
  double position_norm = 0;  ///< |position| [m]
  double along_axis = 0;     ///< component along the true z axis [m] (signed)
  double across_axis = 0;    ///< component perpendicular to the true z axis [m] (>= 0)
  double axis_angle = 0;     ///< angle between true and estimated z axes [rad]
  /// Thesis-style rotation about x and y: the rotation vector of R_true^T R_est, after both are
  /// made canonical in roll (so the z part is ~0) [rad], in the true end frame.
  Eigen::Vector3d rotation_vector = Eigen::Vector3d::Zero();
};

PoseError poseError(const Eigen::Isometry3d& T_world_true, const Eigen::Isometry3d& T_world_est);

/// Summary statistics of a set of errors for one end. Counts use `expected_cycles` as the
/// denominator: a cycle without a valid estimate is a failure.
struct ErrorStats {
  size_t expected_cycles = 0;
  size_t estimates = 0;            ///< cycles with a valid estimate
  Eigen::Vector3d mean_position;   ///< mean estimated position [m] (world)
  Eigen::Vector3d mean_error;      ///< mean of position error vectors [m]
  Eigen::Vector3d std_position;    ///< standard deviation of each coordinate [m]
  Eigen::Vector3d mean_rotation;   ///< mean rotation vector (thesis-style) [rad]
  Eigen::Vector3d std_rotation;    ///< its standard deviation [rad]
  double mean_position_error = 0;  ///< mean |position error| [m]
  double p50_position_error = 0, p95_position_error = 0, max_position_error = 0;  ///< [m]
  double mean_along = 0, mean_across = 0;  ///< mean |along|, mean across [m]
  double mean_axis_angle = 0, p95_axis_angle = 0, max_axis_angle = 0;  ///< [rad]
  /// Fraction of expected cycles with a valid estimate within (position, angle) tolerances.
  double fractionWithin(double position_tol_m, double angle_tol_rad) const;

  std::vector<PoseError> errors;  ///< every scored estimate
  std::vector<Eigen::Vector3d> positions;
};

/// Statistics over `errors` (and the estimated positions) for `expected_cycles` expected cycles.
ErrorStats computeStats(const std::vector<PoseError>& errors,
                        const std::vector<Eigen::Vector3d>& estimated_positions,
                        size_t expected_cycles);

/// Value at quantile q in [0, 1] (linear interpolation); 0 for an empty set.
double percentile(std::vector<double> values, double q);

/// The middle value, the upper of the two middle ones for an even count (a value of the set,
/// not interpolated: robust scales and the drift watch's common part take it); 0 for an empty
/// set. O(n).
double upperMedian(std::vector<double> values);

}  // namespace drill_pipe_pose
