// A level support (floor, catwalk) under an end, and its removal before the axis fit.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "drill_pipe_pose/core/estimator/support_plane.hpp"
#include "drill_pipe_pose/core/estimator/basis.hpp"

namespace drill_pipe_pose {

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

namespace {

/// Whether the layer of the points marked in `use` within plane_threshold of height `h` is a
/// support: it spreads by a standard deviation of at least plane_min_extent along its narrower
/// horizontal direction, and has most of the other points above it.
bool isSupportLayer(const std::vector<Eigen::Vector3f>& points, const std::vector<uint8_t>& use,
                    float h, const EstimatorConfig::AxisFit& config) {
  const float thr = static_cast<float>(config.plane_threshold);
  // Its spread along its narrower horizontal direction: a floor or catwalk spreads both ways; the
  // top band of a lying joint, or the end face of a standing one, is narrow. And the joint stands
  // on it: most of the other points are above it.
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  size_t n = 0;
  long above = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (use[i] && std::abs(p.z() - h) < thr) {
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
  return std::sqrt(std::max(0.0, narrow)) >= config.plane_min_extent;
}

/// Among the points marked in `use`, the horizontal layer 2 plane_threshold thick with the most
/// of them, when it holds at least plane_min_fraction of all the points and is a support
/// (isSupportLayer); `height` receives its mean height. With `densest_support`, the densest of
/// the layers that are supports, among the four densest that do not overlap: two pipes lying
/// side by side show more of their top bands than of the catwalk between them, and those bands,
/// 0.4 m apart, spread both ways (catwalk_twin, seed 191: the two box ends stayed one cluster in
/// a sixth of the cycles).
bool levelLayer(const std::vector<Eigen::Vector3f>& points, const std::vector<uint8_t>& use,
                const EstimatorConfig::AxisFit& config, float* height,
                bool densest_support = false) {
  const float thr = static_cast<float>(config.plane_threshold);
  std::vector<float> z;
  for (size_t i = 0; i < points.size(); ++i)
    if (use[i]) z.push_back(points[i].z());
  // The points each level layer of thickness 2 plane_threshold holds (a sliding window over the
  // sorted heights), by its lowest point.
  std::sort(z.begin(), z.end());
  std::vector<size_t> count(z.size());
  for (size_t lo = 0, hi = 0; lo < z.size(); ++lo) {
    while (hi < z.size() && z[hi] < z[lo] + 2 * thr) ++hi;
    count[lo] = hi - lo;
  }
  const size_t min_n = std::max<size_t>(
      20, static_cast<size_t>(config.plane_min_fraction * static_cast<double>(points.size())));
  // The densest layer (the lowest of equals), then, with densest_support, the densest layer
  // that overlaps none tried, a few at most (each judged over every point).
  constexpr int kMaxLayers = 4;
  std::vector<float> tried;
  for (int k = 0; k < (densest_support ? kMaxLayers : 1); ++k) {
    size_t best_n = 0, best_lo = 0;
    for (size_t lo = 0; lo < z.size(); ++lo) {
      if (count[lo] <= best_n) continue;
      bool overlaps = false;
      for (float t : tried) overlaps = overlaps || std::abs(z[lo] - t) < 2 * thr;
      if (!overlaps) best_n = count[lo], best_lo = lo;
    }
    if (best_n < min_n) return false;
    tried.push_back(z[best_lo]);
    double mean = 0;
    for (size_t i = best_lo; i < best_lo + best_n; ++i) mean += z[i];
    const float h = static_cast<float>(mean / static_cast<double>(best_n));
    if (isSupportLayer(points, use, h, config)) {
      *height = h;
      return true;
    }
  }
  return false;
}

}  // namespace

bool findLevelSupport(const std::vector<Eigen::Vector3f>& points, const AxisLine& axis,
                      double radius, const EstimatorConfig::AxisFit& config, float* height) {
  if (points.size() < 30) return false;
  const float thr = static_cast<float>(config.plane_threshold);
  // The points off the joint's cylinder (by more than plane_threshold) may be a support.
  const Eigen::Vector3f ap = axis.point.cast<float>();
  const Eigen::Vector3f ad = axis.direction.normalized().cast<float>();
  std::vector<uint8_t> off(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f q = points[i] - ap;
    off[i] = std::abs((q - q.dot(ad) * ad).norm() - static_cast<float>(radius)) > thr;
  }
  return levelLayer(points, off, config, height);
}

std::vector<size_t> levelSupportPoints(const std::vector<Eigen::Vector3f>& points,
                                       const EstimatorConfig::AxisFit& config) {
  std::vector<size_t> out;
  float h = 0;
  if (points.size() < 30 ||
      !levelLayer(points, std::vector<uint8_t>(points.size(), 1), config, &h, true))
    return out;
  // The layer's noisy fringe too (depth noise of a surface seen obliquely, a few centimetres at
  // 6 m): everything up to 2 plane_threshold above its height, and below it.
  const float top = h + 2 * static_cast<float>(config.plane_threshold);
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].z() < top) out.push_back(i);
  return out;
}

}  // namespace drill_pipe_pose
