#pragma once
// A ray against a surface of revolution given by its (z, r) profile: the one primitive shared by
// the simulator's renderer (sim::RevolvedShape) and the estimator's projective correspondences
// (ProfileModel::rayHit). Each profile edge revolved about z is a flat ring (annulus), a cylinder
// or a cone; everything is in the profile's own frame [m].

#include <Eigen/Core>

namespace drill_pipe_pose {

/// A ray x(t) = o + t d in the profile's frame, with the terms every edge's test shares (computed
/// once per ray). d need not be unit.
struct RevolvedRay {
  RevolvedRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d);
  double ox, oy, oz, dx, dy, dz;
  double oo, od, dd;  ///< the radial parts: ox^2 + oy^2, ox dx + oy dy, dx^2 + dy^2
};

/// One profile edge (z, r) a -> b revolved about the z axis.
struct RevolvedEdge {
  double z_lo = 0, z_hi = 0;  ///< [m] axial range
  double r_lo = 0, r_hi = 0;  ///< [m] radial range
  double k = 0, c = 0;        ///< r(z) = c + k z (not an annulus)
  bool annulus = false;       ///< perpendicular to the axis: a flat ring at z = z_lo

  /// The edge from profile point (za, ra) to (zb, rb); an annulus when |zb - za| < 1e-9 m.
  static RevolvedEdge fromSegment(double za, double ra, double zb, double rb);

  /// The first intersection of the ray with the edge's surface for t in (t_min, t_max), the
  /// edge's ranges widened by eps [m] (closes cracks between edges); false when there is none.
  bool firstHit(const RevolvedRay& ray, double t_min, double t_max, double eps, double* t) const;
};

}  // namespace drill_pipe_pose
