#include "drill_pipe_pose/core/revolved_ray.hpp"

#include <algorithm>
#include <cmath>

#include "drill_pipe_pose/core/quadratic.hpp"

namespace drill_pipe_pose {

RevolvedRay::RevolvedRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d)
    : ox(o.x()), oy(o.y()), oz(o.z()), dx(d.x()), dy(d.y()), dz(d.z()) {
  oo = ox * ox + oy * oy;
  od = ox * dx + oy * dy;
  dd = dx * dx + dy * dy;
}

RevolvedEdge RevolvedEdge::fromSegment(double za, double ra, double zb, double rb) {
  RevolvedEdge e;
  e.z_lo = std::min(za, zb);
  e.z_hi = std::max(za, zb);
  e.r_lo = std::min(ra, rb);
  e.r_hi = std::max(ra, rb);
  e.annulus = std::abs(zb - za) < 1e-9;
  if (!e.annulus) {
    e.k = (rb - ra) / (zb - za);
    e.c = ra - e.k * za;
  }
  return e;
}

bool RevolvedEdge::firstHit(const RevolvedRay& ray, double t_min, double t_max, double eps,
                            double* t_out) const {
  const double ox = ray.ox, oy = ray.oy, oz = ray.oz, dx = ray.dx, dy = ray.dy, dz = ray.dz;
  if (annulus) {
    if (std::abs(dz) < 1e-15) return false;
    const double t = (z_lo - oz) / dz;
    if (!(t > t_min && t < t_max)) return false;
    const double x = ox + t * dx, y = oy + t * dy, rho2 = x * x + y * y;
    if (r_lo > eps && rho2 < (r_lo - eps) * (r_lo - eps)) return false;
    if (rho2 > (r_hi + eps) * (r_hi + eps)) return false;
    *t_out = t;
    return true;
  }
  // (x^2 + y^2) - (c + k z)^2 = 0 along the ray, with z in [z_lo, z_hi].
  const double w = c + k * oz;
  const double a = ray.dd - k * k * dz * dz;
  const double b = 2.0 * (ray.od - k * dz * w);
  const double cc = ray.oo - w * w;
  double roots[2];
  const int n = solveQuadratic(a, b, cc, roots);
  bool found = false;
  double best = t_max;
  for (int i = 0; i < n; ++i) {
    const double t = roots[i];
    if (!(t > t_min && t < best)) continue;
    const double z = oz + t * dz;
    if (z < z_lo - eps || z > z_hi + eps) continue;
    if (c + k * z < -eps) continue;  // the other nappe of the cone
    best = t;
    found = true;
  }
  if (found) *t_out = best;
  return found;
}

}  // namespace drill_pipe_pose
