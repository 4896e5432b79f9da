#include "drill_pipe_pose/core/estimator/covariance.hpp"

#include <algorithm>
#include <cmath>

namespace drill_pipe_pose {

Eigen::Matrix<double, 6, 6> worldCovariance(const ProfileFitResult& fit,
                                            const EstimatorConfig::Covariance& c) {
  const Eigen::Vector3d e1 = fit.basis.col(0), e2 = fit.basis.col(1), z = fit.basis.col(2);
  // Params: a1 a2 a3 (origin along e1 e2 z), b1 b2 (z tilts toward e1, e2: rotation z x e).
  Eigen::Matrix<double, 6, 5> M = Eigen::Matrix<double, 6, 5>::Zero();
  M.block<3, 1>(0, 0) = e1;
  M.block<3, 1>(0, 1) = e2;
  M.block<3, 1>(0, 2) = z;
  M.block<3, 1>(3, 3) = z.cross(e1);
  M.block<3, 1>(3, 4) = z.cross(e2);
  Eigen::Matrix<double, 6, 6> C = c.inflation * M * fit.covariance * M.transpose();
  Eigen::Matrix3d R;
  R << e1, e2, z;
  const Eigen::Vector3d pos_floor(c.min_lateral_std * c.min_lateral_std,
                                  c.min_lateral_std * c.min_lateral_std,
                                  c.min_axial_std * c.min_axial_std);
  const Eigen::Vector3d rot_floor(c.min_tilt_std * c.min_tilt_std, c.min_tilt_std * c.min_tilt_std,
                                  c.roll_variance);
  C.block<3, 3>(0, 0) += R * pos_floor.asDiagonal() * R.transpose();
  C.block<3, 3>(3, 3) += R * rot_floor.asDiagonal() * R.transpose();
  return 0.5 * (C + C.transpose());
}

Eigen::Matrix<double, 6, 6> calibrationCovariance(const Eigen::Vector3d& z, size_t n, double range,
                                                  double length,
                                                  const EstimatorConfig::Covariance& c) {
  const double t2 = c.extrinsic_translation_std * c.extrinsic_translation_std;
  const double r2 = c.extrinsic_rotation_std * c.extrinsic_rotation_std;
  const double pos = (t2 + r2 * range * range) / static_cast<double>(n);
  const double tilt = (r2 + t2 / std::pow(std::max(length, 0.1), 2)) / static_cast<double>(n);
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();
  C.topLeftCorner<3, 3>() = pos * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d u = z.normalized();
  C.bottomRightCorner<3, 3>() = tilt * (Eigen::Matrix3d::Identity() - u * u.transpose());
  return C;
}

double axialStd(const ProfileFitResult& fit, const EstimatorConfig::Covariance& c) {
  const Eigen::Matrix<double, 6, 6> C = worldCovariance(fit, c);
  const Eigen::Vector3d z = fit.z.normalized();
  return std::sqrt(std::max(0.0, z.dot(C.topLeftCorner<3, 3>() * z)));
}

}  // namespace drill_pipe_pose
