#pragma once
// The pipe-end frame convention (docs/conventions.md): z along the axis out of the joint toward its
// mate, roll about z unobservable and therefore canonical.

#include <Eigen/Geometry>

namespace drill_pipe_pose {

/// Canonical rotation for a pipe-end axis z_world (any length > 0): x = normalise(a - (a.z) z)
/// with a = world x, or world y when |z . world x| > 0.87; y = z x x.
Eigen::Matrix3d canonicalRotation(const Eigen::Vector3d& z_world);

/// T_world_end with origin `origin_world` [m] and canonical roll about `z_world`.
Eigen::Isometry3d canonicalPose(const Eigen::Vector3d& origin_world,
                                const Eigen::Vector3d& z_world);

/// Re-expresses any pose of a pipe end with the canonical roll (same origin and z axis).
inline Eigen::Isometry3d canonicalize(const Eigen::Isometry3d& T_world_end) {
  return canonicalPose(T_world_end.translation(), T_world_end.linear().col(2));
}

}  // namespace drill_pipe_pose

namespace drill_pipe_pose {

/// The pin-end seen from the box-end while stabbing: the pin's origin (its shoulder) in the box
/// frame. All zero when the connection is made up.
struct PinInBoxRelation {
  double axial_standoff = 0;  ///< pin origin along box z [m] (> 0: pin still above the box face)
  double lateral_offset = 0;  ///< distance of the pin origin from the box axis [m]
  double axis_angle = 0;      ///< angle between box z and the reversed pin z [rad]
};

PinInBoxRelation pinInBox(const Eigen::Isometry3d& T_world_box,
                          const Eigen::Isometry3d& T_world_pin);

/// The same from each end's origin and unit axis z (world).
PinInBoxRelation pinInBox(const Eigen::Vector3d& box_origin, const Eigen::Vector3d& box_z,
                          const Eigen::Vector3d& pin_origin, const Eigen::Vector3d& pin_z);

}  // namespace drill_pipe_pose
