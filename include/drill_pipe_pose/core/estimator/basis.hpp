#pragma once
// An orthonormal basis around a direction, shared by the axis fit and the profile registration.

#include <Eigen/Core>
#include <cmath>

namespace drill_pipe_pose {

/// Two unit vectors completing `d` to an orthonormal basis.
inline void orthoBasis(const Eigen::Vector3d& d, Eigen::Vector3d* e1, Eigen::Vector3d* e2) {
  const Eigen::Vector3d a =
      std::abs(d.x()) < 0.8 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  *e1 = (a - a.dot(d) * d).normalized();
  *e2 = d.cross(*e1);
}

}  // namespace drill_pipe_pose
