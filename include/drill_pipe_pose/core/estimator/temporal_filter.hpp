#pragma once
// Optional temporal filter of one pipe end's pose (EstimatorConfig::Temporal): a constant-velocity
// Kalman filter on the origin (a moving pipe is followed without lag once its velocity is known)
// and a random-walk filter on the axis direction, both weighted by the per-cycle covariance.
// A measurement far outside the prediction is held back until `confirmations` more measurements
// agree with it (a real move: the filter restarts from the last of them) - a single wild fit is
// not published, and a true jump costs that many cycles. A new track (the first measurement, a
// gap or a time step backwards) is held the same way (temporal.confirm_start). Only valid
// measurements enter; an end without a measurement stays invalid (the filter never invents a
// pose).

#include <Eigen/Geometry>
#include <cstdint>

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"

namespace drill_pipe_pose {

/// What EndPoseFilter::update did with a measurement.
enum class FilterUpdate {
  kFiltered,   ///< combined with the history
  kRestarted,  ///< the filter (re)started from it (first, after a gap, or a confirmed jump)
  kHeld,       ///< outside the gate, waiting for confirmation: not to be published
  kStarting,   ///< a new track's pose, waiting for confirmation (confirm_start): not published
};

class EndPoseFilter {
 public:
  explicit EndPoseFilter(const EstimatorConfig::Temporal& config = {}) : config_(config) {}

  /// Filters one measurement: origin and unit axis [world] with the 6x6 covariance of
  /// (x y z, rotation about world x y z) at stamp_ns. Returns the filtered origin and axis and
  /// their covariance through the same arguments (unchanged when kHeld).
  FilterUpdate update(int64_t stamp_ns, Eigen::Vector3d* origin, Eigen::Vector3d* axis,
                      Eigen::Matrix<double, 6, 6>* covariance);

  void reset() {
    initialised_ = false;
    held_ = 0;
  }

  /// The last gate test: the measurement's position distance from the prediction [sigma] and
  /// its tilt from the filtered axis against the gate [rad].
  double lastPositionSigma() const { return last_sigma_; }
  double lastTilt() const { return last_tilt_; }
  double lastTiltGate() const { return last_tilt_gate_; }

 private:
  EstimatorConfig::Temporal config_;
  bool initialised_ = false;
  int64_t stamp_ns_ = 0;
  // Zero until the first measurement (initialised_): Eigen leaves a matrix uninitialised, and
  // copying one (a filter restarts by assignment) read indeterminate values.
  Eigen::Matrix<double, 6, 1> x_ = Eigen::Matrix<double, 6, 1>::Zero();  ///< origin, velocity
  Eigen::Matrix<double, 6, 6> P_ = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Vector3d axis_ = Eigen::Vector3d::UnitZ();
  double axis_var_ = 0;  ///< [rad^2] per tilt direction
  // The measurements held outside the gate (the last of them), waiting for confirmation.
  int held_ = 0;
  int64_t held_stamp_ns_ = 0;
  Eigen::Vector3d held_origin_ = Eigen::Vector3d::Zero(), held_axis_ = Eigen::Vector3d::UnitZ();
  Eigen::Matrix3d held_pos_cov_ = Eigen::Matrix3d::Zero();
  double held_tilt_var_ = 0;
  double last_sigma_ = 0, last_tilt_ = 0, last_tilt_gate_ = 0;
  /// Holds a measurement back (returns `kind`) until `confirmations` more agree with it; then
  /// returns restart() (the filter restarted from the last).
  template <typename Restart>
  FilterUpdate holdBack(int64_t stamp_ns, const Eigen::Vector3d& origin,
                        const Eigen::Vector3d& axis, const Eigen::Matrix3d& R_pos, double r_tilt,
                        FilterUpdate kind, const Restart& restart);
};

}  // namespace drill_pipe_pose
