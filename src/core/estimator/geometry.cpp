// Estimator geometry: robust known-radius cylinder-axis fit, the tool-joint profile model and the
// roll-free (5-DoF) profile registration. Eigen only.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/quadratic.hpp"
#include "drill_pipe_pose/core/estimator/stages.hpp"

namespace drill_pipe_pose {

namespace {

/// Two unit vectors completing `d` to an orthonormal basis.
void orthoBasis(const Eigen::Vector3d& d, Eigen::Vector3d* e1, Eigen::Vector3d* e2) {
  const Eigen::Vector3d a =
      std::abs(d.x()) < 0.8 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  *e1 = (a - a.dot(d) * d).normalized();
  *e2 = d.cross(*e1);
}

/// Centroid and major principal direction of points[idx].
bool pca(const std::vector<Eigen::Vector3d>& pts, const std::vector<size_t>& idx,
         Eigen::Vector3d* centroid, Eigen::Vector3d* major) {
  if (idx.size() < 3) return false;
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (size_t i : idx) m += pts[i];
  m /= static_cast<double>(idx.size());
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (size_t i : idx) {
    const Eigen::Vector3d q = pts[i] - m;
    C += q * q.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
  *centroid = m;
  *major = es.eigenvectors().col(2).normalized();
  return std::isfinite(major->x());
}

/// Kasa circle fit of the points projected on the plane normal to d: returns the centre (on the
/// plane through `origin`) when the fitted radius is plausible.
bool circleCentre(const std::vector<Eigen::Vector3d>& pts, const std::vector<size_t>& idx,
                  const Eigen::Vector3d& origin, const Eigen::Vector3d& d, double radius,
                  Eigen::Vector3d* centre) {
  Eigen::Vector3d e1, e2;
  orthoBasis(d, &e1, &e2);
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (size_t i : idx) {
    const Eigen::Vector3d q = pts[i] - origin;
    const double x = q.dot(e1), y = q.dot(e2);
    const Eigen::Vector3d row(x, y, 1.0);
    A += row * row.transpose();
    b += row * (x * x + y * y);
  }
  const Eigen::Vector3d s = A.ldlt().solve(b);  // x^2 + y^2 = 2 a x + 2 b y + c
  const double a = s[0] / 2, bb = s[1] / 2, r2 = s[2] + a * a + bb * bb;
  if (!std::isfinite(r2) || r2 <= 0) return false;
  const double r = std::sqrt(r2);
  if (r < 0.3 * radius || r > 3.0 * radius) return false;
  *centre = origin + a * e1 + bb * e2;
  return true;
}

/// Gauss-Newton with Tukey weights on |distance to axis| - radius. Returns the truncated cost.
double refineCylinder(const std::vector<Eigen::Vector3d>& pts, double radius, double tukey_c,
                      int iterations, AxisLine* axis) {
  Eigen::Vector3d c = axis->point, d = axis->direction.normalized();
  for (int it = 0; it < iterations; ++it) {
    Eigen::Vector3d e1, e2;
    orthoBasis(d, &e1, &e2);
    Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    double t_sum = 0, w_sum = 0;
    for (const auto& p : pts) {
      const Eigen::Vector3d q = p - c;
      const double t = q.dot(d);
      const Eigen::Vector3d qp = q - t * d;
      const double rho = qp.norm();
      if (rho < 1e-9) continue;
      const double res = rho - radius;
      if (std::abs(res) >= tukey_c) continue;
      const double k = 1.0 - (res / tukey_c) * (res / tukey_c);
      const double w = k * k;
      const Eigen::Vector3d u = qp / rho;
      const Eigen::Vector4d J(-u.dot(e1), -u.dot(e2), -t * u.dot(e1), -t * u.dot(e2));
      H += w * J * J.transpose();
      g += w * J * res;
      t_sum += w * t;
      w_sum += w;
    }
    if (w_sum < 5) break;
    H.diagonal().array() += 1e-9 + 1e-6 * H.diagonal().array();
    const Eigen::Vector4d delta = -H.ldlt().solve(g);
    if (!delta.allFinite()) break;
    c += delta[0] * e1 + delta[1] * e2 + (t_sum / w_sum) * d;
    d = (d + delta[2] * e1 + delta[3] * e2).normalized();
    if (delta.head<2>().norm() < 1e-5 && delta.tail<2>().norm() < 1e-5) break;
  }
  axis->point = c;
  axis->direction = d;
  double cost = 0;
  for (const auto& p : pts) {
    const Eigen::Vector3d q = p - c;
    const double res = (q - q.dot(d) * d).norm() - radius;
    cost += std::min(res * res, tukey_c * tukey_c);
  }
  return cost;
}

}  // namespace

std::vector<size_t> removeSupportPlane(const std::vector<Eigen::Vector3f>& points,
                                       const EstimatorConfig::AxisFit& config) {
  std::vector<size_t> keep(points.size());
  for (size_t i = 0; i < points.size(); ++i) keep[i] = i;
  if (config.plane_iterations <= 0 || points.size() < 30) return keep;
  std::mt19937 rng(config.seed + 7);
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  const float thr = static_cast<float>(config.plane_threshold);
  size_t best_n = 0;
  Eigen::Vector3f best_nrm = Eigen::Vector3f::UnitZ();
  float best_d = 0;
  for (int it = 0; it < config.plane_iterations; ++it) {
    const Eigen::Vector3f& a = points[pick(rng)];
    const Eigen::Vector3f& b = points[pick(rng)];
    const Eigen::Vector3f& c = points[pick(rng)];
    Eigen::Vector3f nrm = (b - a).cross(c - a);
    const float len = nrm.norm();
    if (!(len > 1e-6f)) continue;
    nrm /= len;
    const float d = -nrm.dot(a);
    size_t n = 0;
    for (const auto& p : points) n += std::abs(nrm.dot(p) + d) < thr;
    if (n > best_n) best_n = n, best_nrm = nrm, best_d = d;
  }
  if (best_n < std::max<size_t>(20, static_cast<size_t>(config.plane_min_fraction *
                                                        static_cast<double>(points.size()))))
    return keep;
  std::vector<size_t> in;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (size_t i = 0; i < points.size(); ++i)
    if (std::abs(best_nrm.dot(points[i]) + best_d) < thr) {
      in.push_back(i);
      centroid += points[i];
    }
  centroid /= static_cast<float>(in.size());
  // Spread of the inliers in the plane along its narrower direction: a floor or catwalk spreads
  // both ways; the band of a cylinder's side near a tangent plane (or an end face) is narrow.
  Eigen::Matrix3f C = Eigen::Matrix3f::Zero();
  for (size_t i : in) {
    const Eigen::Vector3f q = points[i] - centroid;
    const Eigen::Vector3f qp = q - best_nrm.dot(q) * best_nrm;
    C += qp * qp.transpose();
  }
  C /= static_cast<float>(in.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> es(C);
  // Eigenvalues ascending: [0] ~ 0 (the normal), [1] the narrower in-plane direction.
  if (std::sqrt(std::max(0.0f, es.eigenvalues()[1])) < config.plane_min_extent) return keep;
  keep.clear();
  for (size_t i = 0; i < points.size(); ++i)
    if (!(std::abs(best_nrm.dot(points[i]) + best_d) < thr)) keep.push_back(i);
  return keep;
}

bool findLevelSupport(const std::vector<Eigen::Vector3f>& points, const AxisLine& axis,
                      double radius, const EstimatorConfig::AxisFit& config, float* height) {
  if (points.size() < 30) return false;
  const float thr = static_cast<float>(config.plane_threshold);
  // The points off the joint's cylinder (by more than plane_threshold) may be a support.
  const Eigen::Vector3f ap = axis.point.cast<float>();
  const Eigen::Vector3f ad = axis.direction.normalized().cast<float>();
  std::vector<uint8_t> off(points.size());
  std::vector<float> z;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f q = points[i] - ap;
    off[i] = std::abs((q - q.dot(ad) * ad).norm() - static_cast<float>(radius)) > thr;
    if (off[i]) z.push_back(points[i].z());
  }
  // The level layer of thickness 2 plane_threshold that holds the most of them (a sliding
  // window over the sorted heights).
  std::sort(z.begin(), z.end());
  size_t best_n = 0, best_lo = 0;
  for (size_t lo = 0, hi = 0; lo < z.size(); ++lo) {
    while (hi < z.size() && z[hi] < z[lo] + 2 * thr) ++hi;
    if (hi - lo > best_n) best_n = hi - lo, best_lo = lo;
  }
  if (best_n < std::max<size_t>(20, static_cast<size_t>(config.plane_min_fraction *
                                                        static_cast<double>(points.size()))))
    return false;
  double mean = 0;
  for (size_t i = best_lo; i < best_lo + best_n; ++i) mean += z[i];
  const float h = static_cast<float>(mean / static_cast<double>(best_n));
  // Its spread along its narrower horizontal direction: a floor or catwalk spreads both ways; the
  // top band of a lying joint, or the end face of a standing one, is narrow. And the joint stands
  // on it: most of the other points are above it.
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  size_t n = 0;
  long above = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (off[i] && std::abs(p.z() - h) < thr) {
      const Eigen::Vector2d q = p.head<2>().cast<double>();
      c += q;
      C += q * q.transpose();
      ++n;
    } else {
      above += p.z() > h ? 1 : -1;
    }
  }
  if (n == 0 || above <= 0) return false;
  c /= static_cast<double>(n);
  C = C / static_cast<double>(n) - c * c.transpose();
  const double narrow = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C).eigenvalues()[0];
  if (std::sqrt(std::max(0.0, narrow)) < config.plane_min_extent) return false;
  *height = h;
  return true;
}

AxisFitResult fitCylinderAxis(const std::vector<Eigen::Vector3f>& points, double radius,
                              const EstimatorConfig::AxisFit& config) {
  AxisFitResult result;
  if (points.size() < 10 || !(radius > 0)) return result;
  // Deterministic subsample.
  std::vector<Eigen::Vector3d> pts;
  const size_t stride =
      std::max<size_t>(1, (points.size() + config.max_points - 1) / config.max_points);
  for (size_t i = 0; i < points.size(); i += stride) pts.push_back(points[i].cast<double>());
  std::vector<size_t> all(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) all[i] = i;

  std::vector<AxisLine> hyps;
  AxisLine h;
  if (pca(pts, all, &h.point, &h.direction)) {
    Eigen::Vector3d centre;
    if (circleCentre(pts, all, h.point, h.direction, radius, &centre)) h.point = centre;
    hyps.push_back(h);
  }
  std::mt19937 rng(config.seed);
  std::uniform_int_distribution<size_t> pick(0, pts.size() - 1);
  const double nb2 = config.neighbourhood * config.neighbourhood;
  std::vector<size_t> nb;
  for (int k = 0; k < config.hypotheses; ++k) {
    const Eigen::Vector3d& s = pts[pick(rng)];
    nb.clear();
    for (size_t i = 0; i < pts.size(); ++i)
      if ((pts[i] - s).squaredNorm() < nb2) nb.push_back(i);
    if (nb.size() < 10) continue;
    if (!pca(pts, nb, &h.point, &h.direction)) continue;
    Eigen::Vector3d centre;
    if (circleCentre(pts, nb, h.point, h.direction, radius, &centre)) h.point = centre;
    hyps.push_back(h);
  }
  // Directions spread over the hemisphere (Fibonacci), each with its known-radius circle centre:
  // short, stubby views (a joint standing 0.2 m out of the floor) give PCA no clear direction.
  const double c_wide = 2.5 * config.inlier_threshold;
  if (config.direction_samples > 0) {
    std::vector<std::pair<double, AxisLine>> scored;
    const Eigen::Vector3d centroid = hyps.empty() ? pts[0] : hyps[0].point;
    const int n = config.direction_samples;
    for (int k = 0; k < n; ++k) {
      const double zz = (k + 0.5) / n;  // hemisphere z in (0, 1)
      const double rr = std::sqrt(std::max(0.0, 1 - zz * zz)), phi = k * 2.399963229728653;
      AxisLine a;
      a.direction = Eigen::Vector3d(rr * std::cos(phi), rr * std::sin(phi), zz);
      a.point = centroid;
      if (!circleCentre(pts, all, centroid, a.direction, radius, &a.point)) continue;
      double cost = 0;
      for (const auto& p : pts) {
        const Eigen::Vector3d q = p - a.point;
        const double res = (q - q.dot(a.direction) * a.direction).norm() - radius;
        cost += std::min(res * res, c_wide * c_wide);
      }
      scored.emplace_back(cost, a);
    }
    std::sort(scored.begin(), scored.end(),
              [](const auto& x, const auto& y) { return x.first < y.first; });
    for (size_t k = 0; k < scored.size() && k < 4; ++k) hyps.push_back(scored[k].second);
  }
  if (hyps.empty()) return result;
  double best = std::numeric_limits<double>::infinity();
  AxisLine best_axis;
  for (AxisLine a : hyps) {
    refineCylinder(pts, radius, 2.0 * c_wide, 3, &a);
    const double cost = refineCylinder(pts, radius, c_wide, config.iterations, &a);
    if (cost < best) {
      best = cost;
      best_axis = a;
    }
  }
  refineCylinder(pts, radius, config.inlier_threshold * 1.5, config.iterations, &best_axis);
  double ss = 0;
  size_t n = 0;
  for (const auto& p : pts) {
    const Eigen::Vector3d q = p - best_axis.point;
    const double res = (q - q.dot(best_axis.direction) * best_axis.direction).norm() - radius;
    if (std::abs(res) < config.inlier_threshold) {
      ss += res * res;
      ++n;
    }
  }
  result.axis = best_axis;
  result.inliers = n;
  result.rms = n ? std::sqrt(ss / n) : 0.0;
  result.ok = n >= 10 && best_axis.direction.allFinite() && best_axis.point.allFinite();
  return result;
}

// ---------------------------------------------------------------------------------------------

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
  const int i = std::clamp(static_cast<int>(std::floor((z - g_z0_) / g_res_ + 0.5)), 0, g_nz_ - 1);
  const int j = std::clamp(static_cast<int>(std::floor((r - g_r0_) / g_res_ + 0.5)), 0, g_nr_ - 1);
  const float d = grid_[static_cast<size_t>(i) * g_nr_ + j];
  // Outside the grid: add the distance to it (never smaller than the truth by much).
  const double dz = std::max(0.0, std::max(g_z0_ - z, z - (g_z0_ + (g_nz_ - 1) * g_res_)));
  const double dr = std::max(0.0, r - (g_r0_ + (g_nr_ - 1) * g_res_));
  return d + static_cast<float>(dz + dr);
}

bool ProfileModel::rayHit(const Eigen::Vector3d& q, const Eigen::Vector3d& d, double s_min,
                          double* s_out, Eigen::Vector2d* zr, Eigen::Vector2d* normal) const {
  // Each edge is a surface of revolution: an annulus (constant z), a cylinder or a cone
  // r = r_a + k (z - z_a). With x(s) = q + s d: x^2 + y^2 = r(z(s))^2, a quadratic in s.
  const double qq = q.x() * q.x() + q.y() * q.y(), qd = q.x() * d.x() + q.y() * d.y();
  const double dd = d.x() * d.x() + d.y() * d.y();
  double best = std::numeric_limits<double>::infinity();
  const Edge* hit = nullptr;
  for (size_t k_e = 0; k_e < edges_.size(); ++k_e) {
    const Edge& e = edges_[k_e];
    const double za = e.a.x(), ra = e.a.y(), zb = e.b.x(), rb = e.b.y();
    const double z_lo = std::min(za, zb), z_hi = std::max(za, zb);
    if (std::abs(zb - za) < 1e-9) {
      if (std::abs(d.z()) < 1e-12) continue;
      const double s = (za - q.z()) / d.z();
      if (!(s > s_min && s < best)) continue;
      const double r2 = qq + 2 * s * qd + s * s * dd;
      const double r_lo = std::min(ra, rb), r_hi = std::max(ra, rb);
      if (r2 >= r_lo * r_lo && r2 <= r_hi * r_hi) best = s, hit = &e;
      continue;
    }
    // Cheap rejection: on the part of the ray inside the edge's z slab (and before the best hit
    // so far), the ray never comes within the edge's largest radius.
    {
      double s0 = s_min, s1 = best;
      if (std::abs(d.z()) > 1e-12) {
        double a = (z_lo - q.z()) / d.z(), b = (z_hi - q.z()) / d.z();
        if (a > b) std::swap(a, b);
        s0 = std::max(s0, a - 1e-9);
        s1 = std::min(s1, b + 1e-9);
        if (!(s0 <= s1)) continue;
      } else if (q.z() < z_lo - 1e-9 || q.z() > z_hi + 1e-9) {
        continue;
      }
      double sc = dd > 1e-15 ? -qd / dd : s0;
      sc = std::max(sc, s0);
      if (std::isfinite(s1)) sc = std::min(sc, s1);
      const double r2_min = qq + 2 * sc * qd + sc * sc * dd;
      if (r2_min > edge_r2_max_[k_e] + 1e-9) continue;
    }
    const double k = (rb - ra) / (zb - za);
    const double w0 = ra + k * (q.z() - za), w1 = k * d.z();  // r(s) = w0 + w1 s
    const double A = dd - w1 * w1, B = 2 * (qd - w0 * w1), C = qq - w0 * w0;
    double roots[2];
    const int n = solveQuadratic(A, B, C, roots);
    for (int i = 0; i < n; ++i) {
      const double s = roots[i];
      if (!(s > s_min && s < best)) continue;
      const double zs = q.z() + s * d.z();
      if (zs < z_lo || zs > z_hi || w0 + w1 * s < 0) continue;
      best = s, hit = &e;
    }
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

double profileResidual(const ProfileModel& model, const Eigen::Vector3d& p,
                       const Eigen::Vector3d& origin, const Eigen::Vector3d& z,
                       const Eigen::Vector3d& e1, const Eigen::Vector3d& e2,
                       const Eigen::Vector3f* eye, Eigen::Vector2d* grad, bool* ray_hit) {
  if (ray_hit) *ray_hit = false;
  const Eigen::Vector3d q = p - origin;
  const double zc = q.dot(z), rc = (q - zc * z).norm();
  if (eye) {
    const Eigen::Vector3d ray = p - eye->cast<double>();
    const double range = ray.norm();
    if (range > 0.1) {
      const Eigen::Vector3d dw = ray / range;
      const Eigen::Vector3d qe(q.dot(e1), q.dot(e2), zc), de(dw.dot(e1), dw.dot(e2), dw.dot(z));
      double s;
      Eigen::Vector2d zr, n;
      if (model.rayHit(qe, de, -(range - 0.05), &s, &zr, &n)) {
        if (grad) *grad = n;
        if (ray_hit) *ray_hit = true;
        // Well behind the visible surface (the model hides the point): the distance along the
        // ray; otherwise the signed distance to the tangent plane at the hit.
        if (s < -0.05) return s;
        return n.dot(Eigen::Vector2d(zc, rc) - zr);
      }
    }
  }
  return model.distance(zc, rc, grad);
}

Eigen::Matrix<double, 5, 1> profileJacobian(const Eigen::Vector3d& q, double zc,
                                            const Eigen::Vector3d& u, const Eigen::Vector3d& e1,
                                            const Eigen::Vector3d& e2,
                                            const Eigen::Vector2d& grad) {
  Eigen::Matrix<double, 5, 1> J;
  J << -grad.y() * u.dot(e1), -grad.y() * u.dot(e2), -grad.x(),
      grad.x() * q.dot(e1) - grad.y() * zc * u.dot(e1),
      grad.x() * q.dot(e2) - grad.y() * zc * u.dot(e2);
  return J;
}

RadiusCheck radiusOffset(const ProfileModel& model, double od_radius,
                         const Eigen::Vector3d& origin, const Eigen::Vector3d& z_axis,
                         const std::vector<Eigen::Vector3f>& points,
                         const std::vector<Eigen::Vector3f>& eyes,
                         const std::vector<uint8_t>& inlier_mask) {
  RadiusCheck out;
  const Eigen::Vector3d z = z_axis.normalized();
  Eigen::Vector3d e1, e2;
  orthoBasis(z, &e1, &e2);
  // Normal equations of (pose, radius): [P G; G^T D] [dpose; dr] = [Je; ge], the pose then
  // eliminated (Schur complement): the radius that the points imply whatever the pose.
  Eigen::Matrix<double, 5, 5> P = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> Je = Eigen::Matrix<double, 5, 1>::Zero(),
                              G = Eigen::Matrix<double, 5, 1>::Zero();
  double D = 0, ge = 0, ss = 0;
  size_t n = 0;
  const size_t m = std::min({points.size(), eyes.size(), inlier_mask.size()});
  for (size_t i = 0; i < m; ++i) {
    if (!inlier_mask[i]) continue;
    const Eigen::Vector3d p = points[i].cast<double>();
    Eigen::Vector2d gr;
    bool hit = false;
    const double e = profileResidual(model, p, origin, z, e1, e2, &eyes[i], &gr, &hit);
    if (!hit) continue;
    const Eigen::Vector3d q = p - origin;
    const double zc = q.dot(z);
    const Eigen::Vector3d qp = q - zc * z;
    const double rc = qp.norm();
    if (rc < 1e-9) continue;
    const Eigen::Matrix<double, 5, 1> J = profileJacobian(q, zc, qp / rc, e1, e2, gr);
    P += J * J.transpose();
    Je += J * e;
    ss += e * e;
    ++n;
    // On the tool joint's OD (a radial normal, the surface at the OD): a larger OD moves the
    // surface outward, toward the point.
    const double hit_r = rc - e * gr.y();
    if (std::abs(gr.x()) > 0.1 || std::abs(hit_r - od_radius) > 0.003) continue;
    const double jr = -gr.y();
    G += J * jr;
    D += jr * jr;
    ge += jr * e;
    ++out.points;
  }
  if (n < 10 || out.points < 10) return out;
  Eigen::Matrix<double, 5, 5> Pd = P;
  Pd.diagonal().array() += 1e-9 + 1e-9 * P.diagonal().array();
  const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(Pd);
  const Eigen::Matrix<double, 5, 1> PinvG = ldlt.solve(G);
  const double info = D - G.dot(PinvG);
  if (!(info > 1e-9 * D)) return out;
  out.ok = true;
  // e ~ J dpose + jr dr: dr solves the reduced system; its sign makes a thinner joint negative.
  out.offset = -(ge - PinvG.dot(Je)) / info;
  out.std = std::sqrt(ss / static_cast<double>(n) / info);
  return out;
}

double profileCost(const std::vector<Eigen::Vector3f>& points, const ProfileModel& model,
                   const Eigen::Vector3d& origin, const Eigen::Vector3d& z, double truncation,
                   const std::vector<Eigen::Vector3f>* eyes) {
  if (points.empty()) return 0.0;
  double cost = 0;
  const double T2 = truncation * truncation;
  Eigen::Vector3d e1, e2;
  orthoBasis(z, &e1, &e2);
  for (size_t i = 0; i < points.size(); ++i) {
    const double d = profileResidual(model, points[i].cast<double>(), origin, z, e1, e2,
                                     eyes ? &(*eyes)[i] : nullptr);
    cost += std::min(d * d, T2);
  }
  return cost / points.size();
}

namespace {

/// 1-DoF search along the axis for the shoulder, for one direction (sign) of the axis. Returns
/// the origin's coordinate s along sign * direction from axis.point.
double axialSearch(const std::vector<double>& ts, const std::vector<double>& rs, int sign,
                   const ProfileModel& model, const EstimatorConfig::ProfileFit& config,
                   double* best_cost) {
  const double T2 = config.truncation * config.truncation;
  const auto [t_lo_it, t_hi_it] = std::minmax_element(ts.begin(), ts.end());
  const double t_lo = sign * *t_lo_it, t_hi = sign * *t_hi_it;
  auto searchCost = [&](double s) {
    double cost = 0;
    for (size_t i = 0; i < ts.size(); ++i) {
      const double d = model.coarseDistance(sign * ts[i] - s, rs[i]);
      cost += std::min(d * d, T2);
    }
    return cost;
  };
  // Coarse (2.5 steps) over the whole range, then fine around the best.
  // End-frame z of a point = sign * t - s.
  const double coarse = 2.5 * config.search_step;
  const double lo = std::min(t_lo, t_hi) - model.zMax() - 0.05;
  const double hi = std::max(t_lo, t_hi) - model.zMin() + 0.05;
  double best = std::numeric_limits<double>::infinity(), best_s = lo;
  for (double s = lo; s <= hi; s += coarse) {
    const double cost = searchCost(s);
    if (cost < best) {
      best = cost;
      best_s = s;
    }
  }
  const double s0 = best_s;
  for (double s = s0 - coarse; s <= s0 + coarse + 1e-9; s += config.search_step) {
    const double cost = searchCost(s);
    if (cost < best) {
      best = cost;
      best_s = s;
    }
  }
  *best_cost = best;
  return best_s;
}

/// The radial component of the closest model surface's normal above which a pixel whose ray
/// misses the model counts as one of the joint's side silhouette: within 25 deg of radial, the
/// cylinders and the 18 deg elevator taper, not the end face, the shoulders or the bore.
constexpr double kSilhouetteNormal = 0.9;
}  // namespace

ProfileFitResult refineProfile(const std::vector<Eigen::Vector3f>& points,
                               const std::vector<float>& sigmas, const Eigen::Vector3d& origin,
                               const Eigen::Vector3d& z_axis, const ProfileModel& model,
                               const EstimatorConfig::ProfileFit& config, int iterations,
                               bool lock_axial, const std::vector<Eigen::Vector3f>* eyes) {
  ProfileFitResult res;
  res.label = model.label();
  if (points.size() < 10 || sigmas.size() != points.size()) return res;
  const double T = config.truncation, T2 = T * T;
  Eigen::Vector3d o = origin, z = z_axis.normalized();
  // 2. IRLS Gauss-Newton on the 5 DoF: o += a1 e1 + a2 e2 + a3 z, z += b1 e1 + b2 e2.
  const double z_trust = model.trustedMinZ(config.wear_margin);
  std::vector<Eigen::Vector3d> pts(points.size());
  for (size_t i = 0; i < points.size(); ++i) pts[i] = points[i].cast<double>();
  Eigen::Matrix<double, 5, 5> H_last = Eigen::Matrix<double, 5, 5>::Zero();
  double chi2 = 0;
  size_t n_used = 0;
  // Statistics over all points at the pass's pose (the last pass's are the result's).
  res.inlier_mask.assign(points.size(), 0);
  double cost = 0, ss = 0;
  size_t inl = 0;
  // Silhouette points (below) steer an iteration only when the previous one explained at least
  // config.silhouette_min_inlier_fraction of the points.
  bool silhouettes = false, next_silhouettes = false;
  for (int it = 0; it < iterations + 1; ++it) {
    silhouettes = next_silhouettes;
    const bool last = it == iterations;
    Eigen::Vector3d e1, e2;
    orthoBasis(z, &e1, &e2);
    Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero(), H_cov = H;
    Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
    chi2 = 0;
    n_used = 0;
    cost = ss = 0;
    inl = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
      Eigen::Vector2d gr;
      bool hit = false;
      const double e = profileResidual(model, pts[i], o, z, e1, e2, eyes ? &(*eyes)[i] : nullptr,
                                       &gr, &hit);
      const double d = std::abs(e);
      cost += std::min(d * d, T2);
      const double gate = std::min(T, std::max(0.01, 3.0 * sigmas[i]));
      res.inlier_mask[i] = d < gate;
      if (d < gate) {
        ss += d * d;
        ++inl;
      }
      const Eigen::Vector3d q = pts[i] - o;
      const double zc = q.dot(z);
      // Beyond the trusted tong (worn joints are shorter): the radius still fixes the axis
      // (lateral and tilt), but not the position along it.
      const bool axial_info = zc >= z_trust;
      const Eigen::Vector3d qp = q - zc * z;
      const double rc = qp.norm();
      if (rc < 1e-9) continue;
      if (d > T) continue;
      // A ray that misses the model: a pixel beyond the joint's silhouette as the model sees it.
      // Where its closest model surface faces away from the axis (the joint's sides,
      // kSilhouetteNormal), it is a side pixel that lateral noise (the depth of a neighbouring
      // pixel) moved outward: it counts at that distance, as its twin moved inward (whose ray
      // meets the model) does. Leaving these out biased the simulator's thesis_angled fits
      // (0.75 deg and 5.3 mm without them, 0.64 deg and 4.9 mm with them; a synthetic model of
      // lateral noise alone shows a smaller bias, so that mechanism is not the whole story).
      // Others (beyond the end face or a shoulder, into the bore) do not steer the fit, nor do
      // any while the fit explains few of its points (dark steel: its silhouette's mixed
      // pixels would pull it).
      const bool silhouette = eyes && !hit;
      if (silhouette && !(silhouettes && gr.y() >= kSilhouetteNormal)) continue;
      double sigma = sigmas[i];
      if (config.incidence_noise > 0 && eyes) {
        // The depth noise's growth toward grazing incidence, at the model's normal there.
        const Eigen::Vector3d ray = pts[i] - (*eyes)[i].cast<double>();
        const double range = ray.norm();
        const Eigen::Vector3d n3 = gr.x() * z + gr.y() * (qp / rc);
        sigma += incidenceSigma(config.incidence_noise, range,
                                std::abs(n3.dot(ray)) / (range * n3.norm()));
      }
      const double k = config.huber * sigma;
      const double w = (d <= k ? 1.0 : k / d) / (sigma * sigma);
      Eigen::Matrix<double, 5, 1> J = profileJacobian(q, zc, qp / rc, e1, e2, gr);
      // No pull along the axis from the untrusted part.
      if (!axial_info) J(2) = 0.0;
      H += w * J * J.transpose();
      g += w * J * e;
      // A silhouette point's closest-point distance is an approximation: it steers the fit but
      // adds nothing to the reported certainty.
      if (silhouette) continue;
      H_cov += w * J * J.transpose();
      chi2 += e * e / (sigma * sigma);
      ++n_used;
    }
    next_silhouettes = config.silhouette_points &&
                       static_cast<double>(inl) >=
                           config.silhouette_min_inlier_fraction * static_cast<double>(pts.size());
    H_last = H_cov;
    res.origin = o;
    res.z = z;
    if (last || n_used < 10) break;
    Eigen::Matrix<double, 5, 5> Hd = H;
    Hd.diagonal().array() += 1e-6 * Hd.diagonal().array() + 1e-3;
    Eigen::Matrix<double, 5, 1> gd = g;
    if (lock_axial) {  // solve for the other four
      Hd.row(2).setZero();
      Hd.col(2).setZero();
      Hd(2, 2) = 1.0;
      gd(2) = 0.0;
    }
    const Eigen::Matrix<double, 5, 1> delta = -Hd.ldlt().solve(gd);
    if (!delta.allFinite()) break;
    // Limit the step (robustness far from the optimum).
    const double step_t = delta.head<3>().norm(), step_r = delta.tail<2>().norm();
    const double scale =
        std::min({1.0, 0.05 / std::max(step_t, 1e-12), 0.1 / std::max(step_r, 1e-12)});
    o += scale * (delta[0] * e1 + delta[1] * e2 + delta[2] * z);
    z = (z + scale * (delta[3] * e1 + delta[4] * e2)).normalized();
    // Converged: steps far below the noise (0.1 mm, 0.1 mrad).
    if (step_t < 1e-4 && step_r < 1e-4 && next_silhouettes == silhouettes) {
      it = iterations - 1;  // one more pass to evaluate H at the optimum
    }
  }
  if (n_used < 10) return res;
  // 3. The result: the pose of the last pass (H and the statistics were evaluated there).
  o = res.origin;
  z = res.z;
  res.cost = cost / pts.size();
  res.inliers = inl;
  res.rms = inl ? std::sqrt(ss / inl) : 0.0;
  Eigen::Vector3d e1, e2;
  orthoBasis(z, &e1, &e2);
  res.basis.col(0) = e1;
  res.basis.col(1) = e2;
  res.basis.col(2) = z;
  const double dof = std::max<double>(1.0, static_cast<double>(n_used) - 5.0);
  const double s2 = std::max(1.0, chi2 / dof);
  Eigen::Matrix<double, 5, 5> Hr = H_last;
  Hr.diagonal().array() += 1e-9;
  res.covariance = s2 * Hr.inverse();
  res.ok = res.covariance.allFinite() && o.allFinite() && z.allFinite();
  return res;
}

std::array<ProfileFitResult, 2> fitProfileHypotheses(const std::vector<Eigen::Vector3f>& points,
                                                     const std::vector<float>& sigmas,
                                                     const AxisLine& axis,
                                                     const ProfileModel& model,
                                                     const EstimatorConfig::ProfileFit& config,
                                                     const ProfileModel* search_model,
                                                     const std::vector<Eigen::Vector3f>* eyes) {
  std::array<ProfileFitResult, 2> hyp;
  const ProfileModel& sm = search_model ? *search_model : model;
  hyp[0].label = hyp[1].label = model.label();
  if (points.size() < 10 || sigmas.size() != points.size()) return hyp;
  const Eigen::Vector3d d0 = axis.direction.normalized();
  const size_t stride = std::max<size_t>(1, points.size() / config.search_points);
  std::vector<double> ts, rs;
  for (size_t i = 0; i < points.size(); i += stride) {
    const Eigen::Vector3d q = points[i].cast<double>() - axis.point;
    const double t = q.dot(d0);
    ts.push_back(t);
    rs.push_back((q - t * d0).norm());
  }
  for (int k = 0; k < 2; ++k) {
    const int sign = k == 0 ? 1 : -1;
    double c = 0;
    const double s = axialSearch(ts, rs, sign, sm, config, &c);
    const Eigen::Vector3d z = sign * d0;
    hyp[k] = refineProfile(points, sigmas, axis.point + s * z, z, model, config,
                           config.hypothesis_iterations, false, eyes);
  }
  return hyp;
}

ProfileFitResult fitProfile(const std::vector<Eigen::Vector3f>& points,
                            const std::vector<float>& sigmas, const AxisLine& axis,
                            const ProfileModel& model, const EstimatorConfig::ProfileFit& config) {
  const auto hyp = fitProfileHypotheses(points, sigmas, axis, model, config);
  if (hyp[0].ok && (!hyp[1].ok || hyp[0].cost <= hyp[1].cost)) return hyp[0];
  return hyp[1];
}

size_t seenThroughPixels(const std::vector<OrientedPoint>& samples,
                         const Eigen::Isometry3d& T_world_end,
                         const std::vector<CycleCamera>& cameras, double margin,
                         const EstimatorConfig::Noise& noise, float min_cos_incidence,
                         size_t* predicted) {
  size_t viol_total = 0, pred_total = 0;
  std::vector<uint32_t> viol, pred;
  for (const CycleCamera& cam : cameras) {
    viol.clear();
    pred.clear();
    const Eigen::Isometry3d T_depth_end = cam.T_world_depth.inverse() * T_world_end;
    const Eigen::Matrix3f R = T_depth_end.linear().cast<float>();
    const Eigen::Vector3f t = T_depth_end.translation().cast<float>();
    const float fx = cam.depth.fx(), fy = cam.depth.fy();
    // Pixels rounded in the sensor, then shifted into the delivered image, and read only in
    // cam.crop: the same pixels with full and cropped depth.
    const float cx = cam.depth.cx(), cy = cam.depth.cy();
    const int off_x = static_cast<int>(cam.depth.offsetX()),
              off_y = static_cast<int>(cam.depth.offsetY());
    const int W = cam.image.width;
    const int u0 = cam.crop[0], v0 = cam.crop[1], u1 = cam.crop[2], v1 = cam.crop[3];
    // The camera's centre in the end frame: back faces are skipped before projecting.
    const Eigen::Vector3f eye_end = -(R.transpose() * t);
    for (const OrientedPoint& s : samples) {
      if (s.n.dot(eye_end - s.p) <= 0.0f) continue;  // faces away from the camera
      const Eigen::Vector3f p = R * s.p + t;
      if (!(p.z() > 0.1f)) continue;
      const float range = p.norm();
      const float cos_inc = -(R * s.n).dot(p) / range;
      if (cos_inc <= 0.0f) continue;  // faces away from the camera
      const int u = static_cast<int>(std::floor(fx * p.x() / p.z() + cx + 0.5f)) - off_x;
      const int v = static_cast<int>(std::floor(fy * p.y() / p.z() + cy + 0.5f)) - off_y;
      if (u < u0 || v < v0 || u >= u1 || v >= v1) continue;
      const uint32_t key = static_cast<uint32_t>(v) * W + u;
      if (predicted) pred.push_back(key);
      // Grazing samples are not judged: their depth noise is huge and the silhouette's mixed
      // pixels show the background.
      if (cos_inc < min_cos_incidence) continue;
      // Most samples of a right pose are not seen through: the centre pixel decides cheaply.
      const float zc = cam.image.depthAt(u, v);
      if (zc == zc && zc <= p.z() + static_cast<float>(margin)) continue;
      // Margin: at least `margin`, and 3 sigma of the depth noise at this range and incidence
      // (Fankhauser et al. 2015: + 0.1 z^1.5 theta^2 / (pi/2 - theta)^2 [mm]).
      const float theta = std::acos(std::min(1.0f, cos_inc));
      const float g = theta / (static_cast<float>(M_PI_2) - theta);
      const float sig = depthSigma(noise, p.z()) +
                        static_cast<float>(noise.scale) * 1e-4f * p.z() * std::sqrt(p.z()) * g * g;
      const float m = std::max(static_cast<float>(margin), 3.0f * sig);
      // Seen through only when the whole valid 3x3 neighbourhood lies behind the sample (a
      // one-pixel dead zone at the silhouette, where lateral noise and mixed pixels show the
      // background even for the right pose).
      int valid = 0, behind = 0;
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu < u0 || vv < v0 || uu >= u1 || vv >= v1) continue;
          const float zm = cam.image.depthAt(uu, vv);
          if (!(zm == zm)) continue;
          ++valid;
          if (zm > p.z() + m) ++behind;
        }
      if (valid > 0 && behind == valid) viol.push_back(key);
    }
    // Distinct pixels: the samples are denser than the pixels at short range.
    std::sort(viol.begin(), viol.end());
    viol_total += std::unique(viol.begin(), viol.end()) - viol.begin();
    std::sort(pred.begin(), pred.end());
    pred_total += std::unique(pred.begin(), pred.end()) - pred.begin();
  }
  if (predicted) *predicted = pred_total;
  return viol_total;
}

}  // namespace drill_pipe_pose
