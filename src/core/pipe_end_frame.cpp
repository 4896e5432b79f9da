#include "drill_pipe_pose/core/pipe_end_frame.hpp"

#include <algorithm>
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

namespace drill_pipe_pose {

PinInBoxRelation pinInBox(const Eigen::Isometry3d& T_world_box,
                          const Eigen::Isometry3d& T_world_pin) {
  const Eigen::Vector3d p_box = T_world_box.inverse() * T_world_pin.translation();
  const Eigen::Vector3d z_pin_in_box =
      T_world_box.linear().transpose() * T_world_pin.linear().col(2);
  PinInBoxRelation r;
  r.axial_standoff = p_box.z();
  r.lateral_offset = p_box.head<2>().norm();
  // Made up, the pin's z points into the box: opposite to the box's z.
  r.axis_angle = std::acos(std::clamp(-z_pin_in_box.z(), -1.0, 1.0));
  return r;
}

}  // namespace drill_pipe_pose
