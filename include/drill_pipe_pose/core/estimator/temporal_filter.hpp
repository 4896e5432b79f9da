#pragma once
// Optional temporal filter of one pipe end's pose (EstimatorConfig::Temporal): a constant-velocity
// Kalman filter on the origin (a moving pipe is followed without lag once its velocity is known)
// and a random-walk filter on the axis direction, both weighted by the per-cycle covariance.
// A measurement far outside the prediction (a jump, a re-detected pipe) restarts the filter, as
// do a gap or a time step backwards. Only valid measurements enter; an end without a measurement
// stays invalid (the filter never invents a pose).

#include <Eigen/Geometry>
#include <cstdint>

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"

namespace drill_pipe_pose {

class EndPoseFilter {
 public:
  explicit EndPoseFilter(const EstimatorConfig::Temporal& config = {}) : config_(config) {}

  /// Filters one measurement: origin and unit axis [world] with the 6x6 covariance of
  /// (x y z, rotation about world x y z) at stamp_ns. Returns the filtered origin and axis and
  /// their covariance through the same arguments. True when the filter used the history
  /// (false: it (re)started from this measurement).
  bool update(int64_t stamp_ns, Eigen::Vector3d* origin, Eigen::Vector3d* axis,
              Eigen::Matrix<double, 6, 6>* covariance);

  void reset() { initialised_ = false; }

 private:
  EstimatorConfig::Temporal config_;
  bool initialised_ = false;
  int64_t stamp_ns_ = 0;
  Eigen::Matrix<double, 6, 1> x_;  ///< origin, velocity
  Eigen::Matrix<double, 6, 6> P_;
  Eigen::Vector3d axis_;
  double axis_var_ = 0;  ///< [rad^2] per tilt direction
};

}  // namespace drill_pipe_pose
