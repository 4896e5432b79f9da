// The tool-joint profile model: edges of the revolved (z, r) profile, exact and gridded
// distances, and the ray hit used by the projective correspondences.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/quadratic.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"

namespace drill_pipe_pose {

ProfileModel::ProfileModel(EndLabel label, const ToolJointDimensions& dims) : label_(label) {
  const std::vector<ProfilePoint> prof = toolJointProfile(label, dims);
  tong_length_ = label == EndLabel::kBoxEnd ? dims.box_tong_length : dims.pin_tong_length;
  z_min_ = -(tong_length_ + dims.taperLength());
  z_max_ = label == EndLabel::kBoxEnd ? 0.0 : dims.pin_length;
  double zb = 0;
  for (const auto& q : prof) zb = std::min(zb, q.z);
  const double Rt = dims.tube_od / 2, eps = 1e-9;
  for (size_t i = 0; i < prof.size(); ++i) {
    ProfilePoint a = prof[i], b = prof[(i + 1) % prof.size()];
    const bool a_low = a.z <= zb + eps, b_low = b.z <= zb + eps;
    if (a_low && b_low) continue;  // the model's closing annulus: not part of a real pipe
    if (a_low || b_low) {
      // The tube's outer wall continues; its bore is never seen.
      if (std::abs(a.r - Rt) < eps && std::abs(b.r - Rt) < eps) {
        if (a_low) a.z = zb - 2.0;
        if (b_low) b.z = zb - 2.0;
      } else {
        continue;
      }
    }
    edges_.push_back({Eigen::Vector2d(a.z, a.r), Eigen::Vector2d(b.z, b.r)});
    edge_r2_max_.push_back(std::max(a.r, b.r) * std::max(a.r, b.r));
    r2_max_ = std::max(r2_max_, edge_r2_max_.back());
    surfaces_.push_back(RevolvedEdge::fromSegment(a.z, a.r, b.z, b.r));
  }
  // Distance grid and nearest-edge candidates per cell.
  g_res_ = 0.0025;
  g_z0_ = z_min_ - 0.2;
  g_r0_ = 0.0;
  g_nz_ = static_cast<int>(std::ceil((z_max_ + 0.2 - g_z0_) / g_res_)) + 1;
  g_nr_ = static_cast<int>(std::ceil((dims.tool_joint_od / 2 + 0.15) / g_res_)) + 1;
  const size_t cells = static_cast<size_t>(g_nz_) * g_nr_;
  grid_.resize(cells);
  cell_edges_.assign(cells, {{-1, -1, -1, -1}});
  all_edges_.resize(edges_.size());
  for (size_t k = 0; k < edges_.size(); ++k) all_edges_[k] = static_cast<int8_t>(k);
  const std::vector<int8_t>& all = all_edges_;
  auto nearestEdge = [&](double z, double r) {
    double best = std::numeric_limits<double>::infinity();
    int8_t arg = 0;
    for (size_t k = 0; k < edges_.size(); ++k) {
      const int8_t one = static_cast<int8_t>(k);
      const double d = exactDistance(z, r, nullptr, &one, 1);
      if (d < best) {
        best = d;
        arg = one;
      }
    }
    return arg;
  };
  for (int i = 0; i < g_nz_; ++i)
    for (int j = 0; j < g_nr_; ++j) {
      const size_t c = static_cast<size_t>(i) * g_nr_ + j;
      const double z = g_z0_ + i * g_res_, r = g_r0_ + j * g_res_;
      grid_[c] = static_cast<float>(
          exactDistance(z, r, nullptr, all.data(), static_cast<int>(all.size())));
      // Candidates: nearest edges at the cell's centre and its four corners (cell = +-res/2),
      // plus a margin so that points anywhere in the cell get their true nearest edge.
      std::array<int8_t, 4>& list = cell_edges_[c];
      int n = 0;
      const double h = 0.75 * g_res_;
      for (const auto& off :
           {std::pair<double, double>{0, 0}, {-h, -h}, {-h, h}, {h, -h}, {h, h}}) {
        const int8_t e = nearestEdge(z + off.first, std::max(0.0, r + off.second));
        if (std::find(list.begin(), list.begin() + n, e) == list.begin() + n && n < 4)
          list[n++] = e;
      }
    }
}

double ProfileModel::exactDistance(double z, double r, Eigen::Vector2d* grad, const int8_t* idx,
                                   int n_edges) const {
  const Eigen::Vector2d x(z, r);
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector2d best_closest(0, 0);
  const Edge* best_edge = nullptr;
  for (int k = 0; k < n_edges && idx[k] >= 0; ++k) {
    const Edge& e = edges_[idx[k]];
    const Eigen::Vector2d ab = e.b - e.a;
    const double t = std::clamp((x - e.a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    const Eigen::Vector2d c = e.a + t * ab;
    const double d2 = (x - c).squaredNorm();
    if (d2 < best) {
      best = d2;
      best_closest = c;
      best_edge = &e;
    }
  }
  const double d = std::sqrt(best);
  if (grad) {
    if (d > 1e-9) {
      *grad = (x - best_closest) / d;
    } else if (best_edge) {
      const Eigen::Vector2d ab = (best_edge->b - best_edge->a).normalized();
      *grad = Eigen::Vector2d(ab.y(), -ab.x());
    } else {
      *grad = Eigen::Vector2d(0, 1);
    }
  }
  return d;
}

double ProfileModel::distance(double z, double r, Eigen::Vector2d* grad) const {
  const int i = static_cast<int>(std::floor((z - g_z0_) / g_res_ + 0.5));
  const int j = static_cast<int>(std::floor((r - g_r0_) / g_res_ + 0.5));
  if (i >= 0 && j >= 0 && i < g_nz_ && j < g_nr_)
    return exactDistance(z, r, grad, cell_edges_[static_cast<size_t>(i) * g_nr_ + j].data(), 4);
  return exactDistance(z, r, grad, all_edges_.data(), static_cast<int>(all_edges_.size()));
}

float ProfileModel::coarseDistance(double z, double r) const {
  if (!std::isfinite(z) || !std::isfinite(r)) return std::numeric_limits<float>::infinity();
  // Clamped before the conversion: a point far off the grid (a wild depth) stays defined.
  const int i = static_cast<int>(
      std::clamp(std::floor((z - g_z0_) / g_res_ + 0.5), 0.0, static_cast<double>(g_nz_ - 1)));
  const int j = static_cast<int>(
      std::clamp(std::floor((r - g_r0_) / g_res_ + 0.5), 0.0, static_cast<double>(g_nr_ - 1)));
  const float d = grid_[static_cast<size_t>(i) * g_nr_ + j];
  // Outside the grid: add the distance to it (never smaller than the truth by much).
  const double dz = std::max(0.0, std::max(g_z0_ - z, z - (g_z0_ + (g_nz_ - 1) * g_res_)));
  const double dr = std::max(0.0, r - (g_r0_ + (g_nr_ - 1) * g_res_));
  return d + static_cast<float>(dz + dr);
}

bool ProfileModel::rayHit(const Eigen::Vector3d& q, const Eigen::Vector3d& d, double s_min,
                          double* s_out, Eigen::Vector2d* zr, Eigen::Vector2d* normal) const {
  // Each edge is a surface of revolution: an annulus (constant z), a cylinder or a cone
  // (RevolvedEdge, shared with the simulator's renderer).
  const RevolvedRay ray(q, d);
  const double qq = ray.oo, qd = ray.od, dd = ray.dd;
  {
    // A ray that never comes within the model's largest radius misses every edge.
    const double sc = std::max(s_min, dd > 1e-15 ? -qd / dd : s_min);
    if (qq + 2 * sc * qd + sc * sc * dd > r2_max_ + 1e-9) return false;
  }
  double best = std::numeric_limits<double>::infinity();
  const Edge* hit = nullptr;
  for (size_t k_e = 0; k_e < edges_.size(); ++k_e) {
    const Edge& e = edges_[k_e];
    const RevolvedEdge& surface = surfaces_[k_e];
    if (!surface.annulus) {
      // Cheap rejection: on the part of the ray inside the edge's z slab (and before the best
      // hit so far), the ray never comes within the edge's largest radius.
      double s0 = s_min, s1 = best;
      if (std::abs(d.z()) > 1e-12) {
        double a = (surface.z_lo - q.z()) / d.z(), b = (surface.z_hi - q.z()) / d.z();
        if (a > b) std::swap(a, b);
        s0 = std::max(s0, a - 1e-9);
        s1 = std::min(s1, b + 1e-9);
        if (!(s0 <= s1)) continue;
      } else if (q.z() < surface.z_lo - 1e-9 || q.z() > surface.z_hi + 1e-9) {
        continue;
      }
      double sc = dd > 1e-15 ? -qd / dd : s0;
      sc = std::max(sc, s0);
      if (std::isfinite(s1)) sc = std::min(sc, s1);
      const double r2_min = qq + 2 * sc * qd + sc * sc * dd;
      if (r2_min > edge_r2_max_[k_e] + 1e-9) continue;
    }
    double s;
    if (surface.firstHit(ray, s_min, best, 0.0, &s)) best = s, hit = &e;
  }
  if (!hit) return false;
  *s_out = best;
  const Eigen::Vector3d x = q + best * d;
  const double r = std::sqrt(x.x() * x.x() + x.y() * x.y());
  *zr = Eigen::Vector2d(x.z(), r);
  const Eigen::Vector2d ab = (hit->b - hit->a).normalized();
  Eigen::Vector2d n(ab.y(), -ab.x());
  // Toward the camera: the ray's (z, r) direction at the hit is (d.z, radial part of d).
  const double dr = r > 1e-12 ? (x.x() * d.x() + x.y() * d.y()) / r : 0.0;
  if (n.x() * d.z() + n.y() * dr > 0) n = -n;
  *normal = n;
  return true;
}

}  // namespace drill_pipe_pose
