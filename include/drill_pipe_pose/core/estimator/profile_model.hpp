#pragma once
// The tool-joint model as a revolved 2D profile: exact and gridded distances, ray hits.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/revolved_ray.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

/// A tool-joint model as an open 2D profile (z, r) in its pipe-end frame, with the tube extended
/// beyond the model's truncation, an exact distance and a grid of distances for coarse searches.
class ProfileModel {
 public:
  ProfileModel() = default;
  ProfileModel(EndLabel label, const ToolJointDimensions& dims);

  EndLabel label() const { return label_; }
  /// Distance [m] from (z, r) to the profile; gradient (unit, in (z, r)) of the distance when
  /// `grad` is given, and the signed-free distance along it: d = grad . ((z, r) - closest).
  double distance(double z, double r, Eigen::Vector2d* grad = nullptr) const;
  /// Projective correspondence: the first intersection beyond s_min of the ray x(s) = q + s d
  /// with the model surface (end frame [m]; d unit, pointing away from the camera; s = 0 at the
  /// measured point q). False when the ray misses. `zr` receives the hit's (z, r), `normal` the
  /// unit (z, r) normal of the surface there, oriented toward the camera.
  bool rayHit(const Eigen::Vector3d& q, const Eigen::Vector3d& d, double s_min, double* s,
              Eigen::Vector2d* zr, Eigen::Vector2d* normal) const;
  /// Fast approximate distance from the grid (clamped outside it) [m].
  float coarseDistance(double z, double r) const;
  /// z [m] below which the model is not trusted (worn tong length): -(tong length - margin).
  double trustedMinZ(double wear_margin) const { return -(tong_length_ - wear_margin); }
  /// z range of the tool joint proper (box face / pin nose to the end of the taper) [m].
  double zMin() const { return z_min_; }
  double zMax() const { return z_max_; }

 private:
  struct Edge {
    Eigen::Vector2d a, b;
  };
  EndLabel label_ = EndLabel::kBoxEnd;
  std::vector<Edge> edges_;
  std::vector<double> edge_r2_max_;  ///< per edge, its largest radius squared
  double r2_max_ = 0.0;              ///< the largest of edge_r2_max_
  std::vector<RevolvedEdge> surfaces_;  ///< per edge, its surface of revolution
  double tong_length_ = 0.0, z_min_ = 0.0, z_max_ = 0.0;
  // Distance grid.
  double g_z0_ = 0, g_r0_ = 0, g_res_ = 0.0025;
  int g_nz_ = 0, g_nr_ = 0;
  std::vector<float> grid_;
  /// Per grid cell, the edges nearest to its centre and corners (-1 = none): exact distances at
  /// a fraction of the cost of visiting every edge.
  std::vector<std::array<int8_t, 4>> cell_edges_;
  std::vector<int8_t> all_edges_;
  double exactDistance(double z, double r, Eigen::Vector2d* grad, const int8_t* edges,
                       int n_edges) const;
};

}  // namespace drill_pipe_pose
