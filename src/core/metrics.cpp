#include "drill_pipe_pose/core/metrics.hpp"

#include <algorithm>
#include <cmath>

#include "drill_pipe_pose/core/pipe_end_frame.hpp"

namespace drill_pipe_pose {

PoseError poseError(const Eigen::Isometry3d& T_world_true, const Eigen::Isometry3d& T_world_est) {
  PoseError e;
  const Eigen::Vector3d z_true = T_world_true.linear().col(2).normalized();
  const Eigen::Vector3d z_est = T_world_est.linear().col(2).normalized();
  e.position = T_world_est.translation() - T_world_true.translation();
  e.position_norm = e.position.norm();
  e.along_axis = e.position.dot(z_true);
  e.across_axis = (e.position - e.along_axis * z_true).norm();
  e.axis_angle = std::acos(std::clamp(z_true.dot(z_est), -1.0, 1.0));
  // Roll is never scored: compare the canonical-roll versions of both rotations.
  const Eigen::Matrix3d R_true = canonicalRotation(z_true);
  const Eigen::Matrix3d R_est = canonicalRotation(z_est);
  const Eigen::AngleAxisd aa(R_true.transpose() * R_est);
  e.rotation_vector = aa.angle() * aa.axis();
  return e;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = std::clamp(q, 0.0, 1.0) * (v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const size_t j = std::min(i + 1, v.size() - 1);
  return v[i] + (pos - i) * (v[j] - v[i]);
}

double upperMedian(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double ErrorStats::fractionWithin(double position_tol_m, double angle_tol_rad) const {
  if (expected_cycles == 0) return 0.0;
  size_t ok = 0;
  for (const auto& e : errors)
    if (e.position_norm <= position_tol_m && e.axis_angle <= angle_tol_rad) ++ok;
  return static_cast<double>(ok) / static_cast<double>(std::max(expected_cycles, errors.size()));
}

namespace {

void meanAndStd(const std::vector<Eigen::Vector3d>& v, Eigen::Vector3d* mean, Eigen::Vector3d* sd) {
  mean->setZero();
  sd->setZero();
  if (v.empty()) return;
  for (const auto& x : v) *mean += x;
  *mean /= static_cast<double>(v.size());
  if (v.size() < 2) return;
  for (const auto& x : v) *sd += (x - *mean).cwiseAbs2();
  *sd = (*sd / static_cast<double>(v.size() - 1)).cwiseSqrt();
}

}  // namespace

ErrorStats computeStats(const std::vector<PoseError>& errors,
                        const std::vector<Eigen::Vector3d>& estimated_positions,
                        size_t expected_cycles) {
  ErrorStats s;
  s.expected_cycles = expected_cycles;
  s.estimates = errors.size();
  s.errors = errors;
  s.positions = estimated_positions;
  Eigen::Vector3d unused;
  meanAndStd(estimated_positions, &s.mean_position, &s.std_position);
  std::vector<Eigen::Vector3d> err_vec, rot;
  std::vector<double> norms, angles;
  for (const auto& e : errors) {
    err_vec.push_back(e.position);
    rot.push_back(e.rotation_vector);
    norms.push_back(e.position_norm);
    angles.push_back(e.axis_angle);
    s.mean_along += std::abs(e.along_axis);
    s.mean_across += e.across_axis;
  }
  meanAndStd(err_vec, &s.mean_error, &unused);
  meanAndStd(rot, &s.mean_rotation, &s.std_rotation);
  if (!errors.empty()) {
    const double n = static_cast<double>(errors.size());
    s.mean_along /= n;
    s.mean_across /= n;
    for (double x : norms) s.mean_position_error += x / n;
    for (double x : angles) s.mean_axis_angle += x / n;
  }
  s.p50_position_error = percentile(norms, 0.5);
  s.p95_position_error = percentile(norms, 0.95);
  s.max_position_error = norms.empty() ? 0.0 : *std::max_element(norms.begin(), norms.end());
  s.p95_axis_angle = percentile(angles, 0.95);
  s.max_axis_angle = angles.empty() ? 0.0 : *std::max_element(angles.begin(), angles.end());
  return s;
}

}  // namespace drill_pipe_pose
