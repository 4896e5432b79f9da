#include "drill_pipe_pose/core/pipe_end_frame.hpp"

#include <cmath>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

Eigen::Matrix3d canonicalRotation(const Eigen::Vector3d& z_world) {
  const double norm = z_world.norm();
  if (!(norm > 1e-12) || !std::isfinite(norm))
    fail("canonicalRotation: axis (", z_world.transpose(), ") has no direction");
  const Eigen::Vector3d z = z_world / norm;
  const Eigen::Vector3d a =
      std::abs(z.x()) > 0.87 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d x = (a - a.dot(z) * z).normalized();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

Eigen::Isometry3d canonicalPose(const Eigen::Vector3d& origin_world,
                                const Eigen::Vector3d& z_world) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = canonicalRotation(z_world);
  T.translation() = origin_world;
  return T;
}

}  // namespace drill_pipe_pose
