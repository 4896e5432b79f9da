#include "drill_pipe_pose/core/estimator/temporal_filter.hpp"

#include <algorithm>
#include <cmath>

namespace drill_pipe_pose {

namespace {
/// Mean variance [rad^2] of the tilt of `axis` (rotations about the two directions across it).
double tiltVariance(const Eigen::Matrix3d& rot_cov, const Eigen::Vector3d& axis) {
  const Eigen::Vector3d a = axis.normalized();
  Eigen::Vector3d e1 = a.unitOrthogonal(), e2 = a.cross(e1);
  return 0.5 * (e1.dot(rot_cov * e1) + e2.dot(rot_cov * e2));
}
}  // namespace

template <typename Restart>
FilterUpdate EndPoseFilter::holdBack(int64_t stamp_ns, const Eigen::Vector3d& origin,
                                     const Eigen::Vector3d& axis, const Eigen::Matrix3d& R_pos,
                                     double r_tilt, FilterUpdate kind, const Restart& restart) {
  // Held until `confirmations` more measurements agree with the held one (within the gate of
  // both covariances, the position allowed max_speed of motion in between); then the filter
  // restarts from the last.
  const Eigen::Vector3d meas_axis = axis.normalized();
  bool agrees = false;
  const double dt_held = (stamp_ns - held_stamp_ns_) * 1e-9;
  if (held_ > 0 && dt_held > 0.0 && dt_held <= config_.max_gap) {
    const Eigen::Vector3d dp = origin - held_origin_;
    const double motion = config_.max_speed * dt_held;
    const Eigen::Matrix3d Sh =
        held_pos_cov_ + R_pos + motion * motion * Eigen::Matrix3d::Identity();
    const double dh2 = dp.dot(Sh.ldlt().solve(dp));
    const double th = std::acos(std::clamp(meas_axis.dot(held_axis_), -1.0, 1.0));
    agrees = dh2 <= config_.gate_sigma * config_.gate_sigma &&
             th <= config_.gate_sigma * std::sqrt(held_tilt_var_ + r_tilt);
  }
  held_ = agrees ? held_ + 1 : 1;
  if (held_ > config_.confirmations) return restart();
  held_stamp_ns_ = stamp_ns;
  held_origin_ = origin;
  held_axis_ = meas_axis;
  held_pos_cov_ = R_pos;
  held_tilt_var_ = r_tilt;
  return kind;
}

FilterUpdate EndPoseFilter::update(int64_t stamp_ns, Eigen::Vector3d* origin,
                                   Eigen::Vector3d* axis, Eigen::Matrix<double, 6, 6>* covariance) {
  const Eigen::Matrix3d R_pos = covariance->topLeftCorner<3, 3>();
  const double r_tilt = tiltVariance(covariance->bottomRightCorner<3, 3>(), *axis);
  const double dt = (stamp_ns - stamp_ns_) * 1e-9;
  auto restart = [&]() {
    initialised_ = true;
    stamp_ns_ = stamp_ns;
    x_.head<3>() = *origin;
    x_.tail<3>().setZero();
    P_.setZero();
    P_.topLeftCorner<3, 3>() = R_pos;
    P_.bottomRightCorner<3, 3>() =
        Eigen::Matrix3d::Identity() * config_.max_speed * config_.max_speed;
    axis_ = axis->normalized();
    axis_var_ = r_tilt;
    held_ = 0;
    return FilterUpdate::kRestarted;
  };
  if (!initialised_ || dt <= 0.0 || dt > config_.max_gap) {
    // A new track (the first measurement, or one after a gap or a step back in time): like a
    // jump, its first pose is held until the next agrees (confirm_start), so that one wild fit
    // of a hard view (a dark joint, a clutter of ends) is never published alone.
    if (!config_.confirm_start || config_.confirmations <= 0) return restart();
    initialised_ = false;
    last_sigma_ = last_tilt_ = last_tilt_gate_ = 0;
    return holdBack(stamp_ns, *origin, *axis, R_pos, r_tilt, FilterUpdate::kStarting, restart);
  }

  // Predict (constant velocity, white acceleration of spectral density q).
  Eigen::Matrix<double, 6, 6> F = Eigen::Matrix<double, 6, 6>::Identity();
  F.topRightCorner<3, 3>() = dt * Eigen::Matrix3d::Identity();
  const double q = config_.acceleration_density;
  Eigen::Matrix<double, 6, 6> Q = Eigen::Matrix<double, 6, 6>::Zero();
  Q.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * q * dt * dt * dt / 3.0;
  Q.topRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * q * dt * dt / 2.0;
  Q.bottomLeftCorner<3, 3>() = Q.topRightCorner<3, 3>();
  Q.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * q * dt;
  const Eigen::Matrix<double, 6, 1> x_pred = F * x_;
  const Eigen::Matrix<double, 6, 6> P_pred = F * P_ * F.transpose() + Q;
  const double axis_var_pred = axis_var_ + config_.tilt_rate_density * dt;

  // Gates: position (Mahalanobis, 3 DoF) and tilt.
  const Eigen::Vector3d innov = *origin - x_pred.head<3>();
  const Eigen::Matrix3d S = P_pred.topLeftCorner<3, 3>() + R_pos;
  const double d2 = innov.dot(S.ldlt().solve(innov));
  Eigen::Vector3d meas_axis = axis->normalized();
  const double cos_a = std::clamp(meas_axis.dot(axis_), -1.0, 1.0);
  const double tilt = std::acos(cos_a);
  const double tilt_gate = config_.gate_sigma * std::sqrt(axis_var_pred + r_tilt);
  last_sigma_ = std::sqrt(std::max(0.0, d2));
  last_tilt_ = tilt;
  last_tilt_gate_ = tilt_gate;
  if (!(d2 <= config_.gate_sigma * config_.gate_sigma) || tilt > tilt_gate) {
    if (config_.confirmations <= 0) return restart();
    // Outside the gate: a wild fit, or the pipe moved.
    return holdBack(stamp_ns, *origin, *axis, R_pos, r_tilt, FilterUpdate::kHeld, restart);
  }
  held_ = 0;

  // Update.
  Eigen::Matrix<double, 6, 3> H = Eigen::Matrix<double, 6, 3>::Zero();
  H.topRows<3>().setIdentity();  // H^T: the measurement is the position
  const Eigen::Matrix<double, 6, 3> K = P_pred * H * S.inverse();
  x_ = x_pred + K * innov;
  P_ = (Eigen::Matrix<double, 6, 6>::Identity() - K * H.transpose()) * P_pred;
  P_ = 0.5 * (P_ + P_.transpose());
  const double k_axis = axis_var_pred / (axis_var_pred + r_tilt);
  axis_ = (axis_ + k_axis * (meas_axis - axis_)).normalized();
  axis_var_ = (1.0 - k_axis) * axis_var_pred;
  stamp_ns_ = stamp_ns;

  *origin = x_.head<3>();
  *axis = axis_;
  covariance->topLeftCorner<3, 3>() = P_.topLeftCorner<3, 3>();
  covariance->topRightCorner<3, 3>().setZero();
  covariance->bottomLeftCorner<3, 3>().setZero();
  // Rotation block: the filtered tilt variance across the axis, the roll variance kept.
  const double roll_var = axis_.dot(covariance->bottomRightCorner<3, 3>() * axis_);
  covariance->bottomRightCorner<3, 3>() =
      axis_var_ * (Eigen::Matrix3d::Identity() - axis_ * axis_.transpose()) +
      roll_var * axis_ * axis_.transpose();
  return FilterUpdate::kFiltered;
}

}  // namespace drill_pipe_pose
