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
  return pinInBox(T_world_box.translation(), T_world_box.linear().col(2),
                  T_world_pin.translation(), T_world_pin.linear().col(2));
}

PinInBoxRelation pinInBox(const Eigen::Vector3d& box_origin, const Eigen::Vector3d& box_z,
                          const Eigen::Vector3d& pin_origin, const Eigen::Vector3d& pin_z) {
  const Eigen::Vector3d d = pin_origin - box_origin;
  PinInBoxRelation r;
  r.axial_standoff = d.dot(box_z);
  r.lateral_offset = (d - r.axial_standoff * box_z).norm();
  // Made up, the pin's z points into the box: opposite to the box's z.
  r.axis_angle = std::acos(std::clamp(-pin_z.dot(box_z), -1.0, 1.0));
  return r;
}

}  // namespace drill_pipe_pose
