// The robust known-radius cylinder-axis fit (global and local PCA hypotheses, Gauss-Newton with
// Tukey weights). Eigen only.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "drill_pipe_pose/core/estimator/axis_fit.hpp"
#include "drill_pipe_pose/core/estimator/basis.hpp"

namespace drill_pipe_pose {

namespace {

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

}  // namespace drill_pipe_pose
