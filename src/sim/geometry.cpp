#include "drill_pipe_pose/sim/geometry.hpp"

#include <cmath>
#include <limits>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/quadratic.hpp"

namespace drill_pipe_pose::sim {

namespace {
constexpr double kUnbounded = 1e4;  // [m] extent used for "infinite" planes
constexpr double kEps = 1e-9;       // [m] tolerance on edge ranges (closes cracks between edges)
}  // namespace

bool intersectSlabs(const Eigen::AlignedBox3d& box, const Ray& ray, double t_min, double t_max,
                    double* t_enter, double* t_exit) {
  double t0 = -std::numeric_limits<double>::infinity(),
         t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double d = ray.d[a];
    if (std::abs(d) < 1e-15) {
      if (ray.o[a] < box.min()[a] || ray.o[a] > box.max()[a]) return false;
      continue;
    }
    const double inv = 1.0 / d;
    double ta = (box.min()[a] - ray.o[a]) * inv, tb = (box.max()[a] - ray.o[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) t0 = ta;
    if (tb < t1) t1 = tb;
    if (t0 > t1) return false;
  }
  if (t1 <= t_min || t0 >= t_max) return false;
  *t_enter = t0;
  *t_exit = t1;
  return true;
}

RevolvedShape::RevolvedShape(const std::vector<ProfilePoint>& profile) : profile_(profile) {
  if (profile.size() < 3) fail("RevolvedShape: a profile needs >= 3 points, got ", profile.size());
  z_min_ = z_max_ = profile[0].z;
  for (size_t i = 0; i < profile.size(); ++i) {
    const ProfilePoint& a = profile[i];
    const ProfilePoint& b = profile[(i + 1) % profile.size()];
    if (a.r < 0.0 || !std::isfinite(a.r) || !std::isfinite(a.z))
      fail("RevolvedShape: profile point ", i, " = (", a.z, ", ", a.r, ") is invalid");
    z_min_ = std::min(z_min_, a.z);
    z_max_ = std::max(z_max_, a.z);
    r_max_ = std::max(r_max_, a.r);
    const double dz = b.z - a.z, dr = b.r - a.r, len = std::hypot(dz, dr);
    if (len < 1e-12) continue;  // duplicate point
    Edge e;
    e.nz = dr / len;
    e.nr = -dz / len;
    e.surface = RevolvedEdge::fromSegment(a.z, a.r, b.z, b.r);
    if (e.surface.annulus && e.surface.r_hi < 1e-12) continue;  // degenerate: on the axis
    edges_.push_back(e);
  }
}

bool RevolvedShape::intersect(const Ray& ray, double t_min, double t_max, LocalHit* hit) const {
  const Eigen::AlignedBox3d bounds(Eigen::Vector3d(-r_max_, -r_max_, z_min_),
                                   Eigen::Vector3d(r_max_, r_max_, z_max_));
  double te, tx;
  if (!intersectSlabs(bounds, ray, t_min, t_max, &te, &tx)) return false;
  double best = std::min(t_max, tx + 1e-6);
  const Edge* best_edge = nullptr;
  const RevolvedRay r(ray.o, ray.d);
  for (const Edge& e : edges_) {
    double t;
    if (e.surface.firstHit(r, t_min, best, kEps, &t)) {
      best = t;
      best_edge = &e;
    }
  }
  if (!best_edge) return false;
  hit->t = best;
  if (best_edge->surface.annulus) {
    hit->n = Eigen::Vector3d(0, 0, best_edge->nz);
  } else {
    const double x = ray.o.x() + best * ray.d.x(), y = ray.o.y() + best * ray.d.y();
    const double rho = std::hypot(x, y);
    if (rho < 1e-12)
      hit->n = Eigen::Vector3d(0, 0, best_edge->nz >= 0 ? 1.0 : -1.0);
    else
      hit->n = Eigen::Vector3d(best_edge->nr * x / rho, best_edge->nr * y / rho, best_edge->nz);
  }
  return true;
}

Shape Shape::plane(double size_x, double size_y) {
  Shape s;
  s.type = ShapeType::kPlane;
  s.half_extents = Eigen::Vector3d(size_x / 2, size_y / 2, 0.0);
  return s;
}

Shape Shape::box(const Eigen::Vector3d& size) {
  if (!(size.minCoeff() > 0.0)) fail("box: size (", size.transpose(), ") must be > 0");
  Shape s;
  s.type = ShapeType::kBox;
  s.half_extents = size / 2;
  return s;
}

Shape Shape::cylinder(double radius, double z_min, double z_max) {
  if (!(radius > 0.0) || !(z_max > z_min))
    fail("cylinder: radius = ", radius, " must be > 0 and z_max = ", z_max, " > z_min = ", z_min);
  Shape s;
  s.type = ShapeType::kCylinder;
  s.radius = radius;
  s.z_min = z_min;
  s.z_max = z_max;
  return s;
}

Shape Shape::revolvedProfile(const std::vector<ProfilePoint>& profile) {
  Shape s;
  s.type = ShapeType::kRevolved;
  s.revolved = std::make_shared<RevolvedShape>(profile);
  return s;
}

Eigen::AlignedBox3d Shape::localBounds() const {
  switch (type) {
    case ShapeType::kPlane: {
      const double hx = half_extents.x() > 0 ? half_extents.x() : kUnbounded;
      const double hy = half_extents.y() > 0 ? half_extents.y() : kUnbounded;
      return Eigen::AlignedBox3d(Eigen::Vector3d(-hx, -hy, -1e-6), Eigen::Vector3d(hx, hy, 1e-6));
    }
    case ShapeType::kBox:
      return Eigen::AlignedBox3d(-half_extents, half_extents);
    case ShapeType::kCylinder:
      return Eigen::AlignedBox3d(Eigen::Vector3d(-radius, -radius, z_min),
                                 Eigen::Vector3d(radius, radius, z_max));
    case ShapeType::kRevolved: {
      const double r = revolved->rMax();
      return Eigen::AlignedBox3d(Eigen::Vector3d(-r, -r, revolved->zMin()),
                                 Eigen::Vector3d(r, r, revolved->zMax()));
    }
  }
  return Eigen::AlignedBox3d();
}

namespace {

bool intersectPlane(const Eigen::Vector3d& half, const Ray& ray, double t_min, double t_max,
                    LocalHit* hit) {
  if (std::abs(ray.d.z()) < 1e-15) return false;
  const double t = -ray.o.z() / ray.d.z();
  if (!(t > t_min && t < t_max)) return false;
  if (half.x() > 0 && std::abs(ray.o.x() + t * ray.d.x()) > half.x()) return false;
  if (half.y() > 0 && std::abs(ray.o.y() + t * ray.d.y()) > half.y()) return false;
  hit->t = t;
  hit->n = Eigen::Vector3d::UnitZ();
  return true;
}

bool intersectBox(const Eigen::Vector3d& half, const Ray& ray, double t_min, double t_max,
                  LocalHit* hit) {
  double t_enter = -std::numeric_limits<double>::infinity();
  double t_exit = std::numeric_limits<double>::infinity();
  int ax_enter = -1, ax_exit = -1;
  for (int a = 0; a < 3; ++a) {
    const double d = ray.d[a];
    if (std::abs(d) < 1e-15) {
      if (std::abs(ray.o[a]) > half[a]) return false;
      continue;
    }
    double ta = (-half[a] - ray.o[a]) / d, tb = (half[a] - ray.o[a]) / d;
    if (ta > tb) std::swap(ta, tb);
    if (ta > t_enter) {
      t_enter = ta;
      ax_enter = a;
    }
    if (tb < t_exit) {
      t_exit = tb;
      ax_exit = a;
    }
    if (t_enter > t_exit) return false;
  }
  double t;
  int ax;
  if (t_enter > t_min) {
    t = t_enter;
    ax = ax_enter;
  } else {
    t = t_exit;
    ax = ax_exit;
  }
  if (!(t > t_min && t < t_max) || ax < 0) return false;
  hit->t = t;
  hit->n = Eigen::Vector3d::Zero();
  const double p = ray.o[ax] + t * ray.d[ax];
  hit->n[ax] = p >= 0 ? 1.0 : -1.0;
  return true;
}

bool intersectCylinder(double radius, double z_min, double z_max, const Ray& ray, double t_min,
                       double t_max, LocalHit* hit) {
  double best = t_max;
  bool found = false;
  const double ox = ray.o.x(), oy = ray.o.y(), dx = ray.d.x(), dy = ray.d.y();
  const double a = dx * dx + dy * dy;
  if (a > 1e-15) {
    const double b = 2.0 * (ox * dx + oy * dy), c = ox * ox + oy * oy - radius * radius;
    const double disc = b * b - 4.0 * a * c;
    if (disc >= 0.0) {
      const double sq = std::sqrt(disc);
      for (double t : {(-b - sq) / (2 * a), (-b + sq) / (2 * a)}) {
        if (!(t > t_min && t < best)) continue;
        const double z = ray.o.z() + t * ray.d.z();
        if (z < z_min || z > z_max) continue;
        best = t;
        found = true;
        const double x = ox + t * dx, y = oy + t * dy;
        hit->n = Eigen::Vector3d(x / radius, y / radius, 0.0);
        break;
      }
    }
  }
  if (std::abs(ray.d.z()) > 1e-15) {
    for (double zc : {z_min, z_max}) {
      const double t = (zc - ray.o.z()) / ray.d.z();
      if (!(t > t_min && t < best)) continue;
      const double x = ox + t * dx, y = oy + t * dy;
      if (x * x + y * y > radius * radius) continue;
      best = t;
      found = true;
      hit->n = Eigen::Vector3d(0, 0, zc == z_max ? 1.0 : -1.0);
    }
  }
  if (found) hit->t = best;
  return found;
}

}  // namespace

bool Shape::intersect(const Ray& ray, double t_min, double t_max, LocalHit* hit) const {
  switch (type) {
    case ShapeType::kPlane:
      return intersectPlane(half_extents, ray, t_min, t_max, hit);
    case ShapeType::kBox:
      return intersectBox(half_extents, ray, t_min, t_max, hit);
    case ShapeType::kCylinder:
      return intersectCylinder(radius, z_min, z_max, ray, t_min, t_max, hit);
    case ShapeType::kRevolved:
      return revolved->intersect(ray, t_min, t_max, hit);
  }
  return false;
}

Eigen::AlignedBox3d transformBox(const Eigen::AlignedBox3d& local, const Eigen::Isometry3d& T) {
  Eigen::AlignedBox3d out;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d c((i & 1) ? local.max().x() : local.min().x(),
                            (i & 2) ? local.max().y() : local.min().y(),
                            (i & 4) ? local.max().z() : local.min().z());
    out.extend(T * c);
  }
  return out;
}

}  // namespace drill_pipe_pose::sim
