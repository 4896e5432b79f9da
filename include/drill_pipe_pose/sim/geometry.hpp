#pragma once
// Exact ray casting against the simulator's primitives, each in its own local frame [m]:
//   plane     z = 0, normal +z, optionally finite (|x| <= hx, |y| <= hy)
//   box       axis-aligned |x| <= hx, |y| <= hy, |z| <= hz
//   cylinder  x^2 + y^2 <= r^2, z_min <= z <= z_max, capped
//   revolved  the solid of revolution about z of a closed (z, r) profile (core/tool_joint.hpp),
//             intersected exactly per profile edge (cylinder / cone-frustum quadratic or annulus)
// Hits are the first surface crossing with t in (t_min, t_max). Normals are the outward unit
// normals of the surface (a ray starting inside a solid sees an outward normal facing away).

#include <Eigen/Geometry>
#include <memory>
#include <vector>

#include "drill_pipe_pose/core/revolved_ray.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose::sim {

/// A ray o + t d (t >= 0) [m]; d must have unit length so that t is a distance.
struct Ray {
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  Eigen::Vector3d d = Eigen::Vector3d::UnitZ();
};

/// A hit in the frame the ray was given in.
struct LocalHit {
  double t = 0.0;                                ///< [m] distance along the ray
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();  ///< outward unit normal
};

/// Slab test of a ray against an axis-aligned box. On success (the ray's parameter interval
/// [t_enter, t_exit] overlaps (t_min, t_max)) writes the interval and returns true.
bool intersectSlabs(const Eigen::AlignedBox3d& box, const Ray& ray, double t_min, double t_max,
                    double* t_enter, double* t_exit);

/// A closed (z, r) profile revolved about the local z axis, prepared for exact ray casting.
class RevolvedShape {
 public:
  /// `profile` as toolJointProfile() returns it: closed (last joins first), counter-clockwise in
  /// (z, r), r >= 0. Throws InputError for fewer than 3 points or a negative radius.
  explicit RevolvedShape(const std::vector<ProfilePoint>& profile);

  /// First crossing of the surface with t in (t_min, t_max), ray in the shape's frame.
  bool intersect(const Ray& ray, double t_min, double t_max, LocalHit* hit) const;

  double zMin() const { return z_min_; }  ///< [m]
  double zMax() const { return z_max_; }  ///< [m]
  double rMax() const { return r_max_; }  ///< [m]
  const std::vector<ProfilePoint>& profile() const { return profile_; }

 private:
  struct Edge {
    RevolvedEdge surface;  ///< the revolved edge (core/revolved_ray.hpp)
    double nz, nr;         ///< outward unit normal in (z, r)
  };
  std::vector<ProfilePoint> profile_;
  std::vector<Edge> edges_;
  double z_min_ = 0, z_max_ = 0, r_max_ = 0;
};

enum class ShapeType { kPlane, kBox, kCylinder, kRevolved };

/// One primitive in its local frame (see the file comment).
struct Shape {
  ShapeType type = ShapeType::kBox;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();  ///< box / plane (<= 0: unbounded) [m]
  double radius = 0.0;                                     ///< cylinder [m]
  double z_min = 0.0, z_max = 0.0;                         ///< cylinder axial range [m]
  std::shared_ptr<const RevolvedShape> revolved;           ///< body of revolution

  /// Plane z = 0 of size_x by size_y [m] centred on the origin; 0 = unbounded in that direction.
  static Shape plane(double size_x, double size_y);
  /// Box of the given full edge lengths [m], centred on the origin.
  static Shape box(const Eigen::Vector3d& size);
  /// Capped cylinder about z from z_min to z_max [m].
  static Shape cylinder(double radius, double z_min, double z_max);
  /// Body of revolution of a closed (z, r) profile [m].
  static Shape revolvedProfile(const std::vector<ProfilePoint>& profile);

  /// Bounds in the local frame (unbounded planes: +-1e4 m).
  Eigen::AlignedBox3d localBounds() const;
  /// First hit with t in (t_min, t_max), ray in the local frame.
  bool intersect(const Ray& ray, double t_min, double t_max, LocalHit* hit) const;
};

/// Axis-aligned bounds of `local` transformed by T (the 8 corners).
Eigen::AlignedBox3d transformBox(const Eigen::AlignedBox3d& local, const Eigen::Isometry3d& T);

}  // namespace drill_pipe_pose::sim
