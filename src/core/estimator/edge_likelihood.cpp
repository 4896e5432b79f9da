// The depth pixels around an end against a model pose rendered into each camera, with the
// pixels beside the model's depth steps expected to be missing or mixed.

#include "drill_pipe_pose/core/estimator/edge_likelihood.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace drill_pipe_pose {

namespace {

/// The region [u0, u1) x [v0, v1) of the camera's delivered depth image that the end's region
/// (end frame: |x|, |y| <= radius, z in [z_lo, z_hi]) projects into, grown by a pixel and cut to
/// the camera's crop; false when it is not in front of the camera or too small to judge.
bool endRegion(const CycleCamera& cam, const Eigen::Isometry3d& T_depth_end, double radius,
               double z_lo, double z_hi, std::array<int, 4>* rect) {
  double u_lo = 1e9, v_lo = 1e9, u_hi = -1e9, v_hi = -1e9;
  for (double x : {-radius, radius})
    for (double y : {-radius, radius})
      for (double z : {z_lo, z_hi}) {
        Eigen::Vector2d uv;
        if (!cam.depth.project(T_depth_end * Eigen::Vector3d(x, y, z), &uv)) return false;
        u_lo = std::min(u_lo, uv.x());
        u_hi = std::max(u_hi, uv.x());
        v_lo = std::min(v_lo, uv.y());
        v_hi = std::max(v_hi, uv.y());
      }
  // Bounds far outside the image become ints without overflow (clamped first).
  auto px = [](double x) { return static_cast<int>(std::clamp(x, -1e6, 1e6)); };
  (*rect)[0] = std::max(cam.crop[0], px(std::floor(u_lo)) - 1);
  (*rect)[1] = std::max(cam.crop[1], px(std::floor(v_lo)) - 1);
  (*rect)[2] = std::min(cam.crop[2], px(std::ceil(u_hi)) + 2);
  (*rect)[3] = std::min(cam.crop[3], px(std::ceil(v_hi)) + 2);
  return (*rect)[2] - (*rect)[0] >= 3 && (*rect)[3] - (*rect)[1] >= 3;
}

}  // namespace

std::vector<EdgeRegion> edgeRegions(const ProfileModel& model, double radius,
                                    const Eigen::Isometry3d& T_world_end,
                                    const std::vector<CycleCamera>& cameras,
                                    const EstimatorConfig::Edges& edges, double reach) {
  const double z_lo = model.zMax() - edges.region_below - reach;
  const double z_hi = model.zMax() + edges.region_above + reach;
  std::vector<EdgeRegion> regions(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    const Eigen::Isometry3d T_depth_end = cameras[c].T_world_depth.inverse() * T_world_end;
    if (!endRegion(cameras[c], T_depth_end, radius, z_lo, z_hi, &regions[c].rect))
      regions[c].rect = {{0, 0, 0, 0}};
  }
  return regions;
}

namespace {

/// The model's optical depth at each pixel centre of the camera's region (NaN: the ray misses
/// it, or the region's mask leaves the pixel out).
void renderRegion(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                  const CycleCamera& cam, const EdgeRegion& region, std::vector<float>* out) {
  const auto [u0, v0, u1, v1] = region.rect;
  const int w = u1 - u0;
  out->assign(static_cast<size_t>(w) * (v1 - v0), std::numeric_limits<float>::quiet_NaN());
  const Eigen::Isometry3d T_end_depth = T_world_end.inverse() * cam.T_world_depth;
  const Eigen::Matrix3d R = T_end_depth.linear();
  const Eigen::Vector3d eye = T_end_depth.translation();
  for (int v = v0; v < v1; ++v)
    for (int u = u0; u < u1; ++u) {
      const size_t i = static_cast<size_t>(v - v0) * w + (u - u0);
      if (!region.mask.empty() && !(region.mask[i] & EdgeRegion::kRendered)) {
        (*out)[i] = region.fixed_depth[i];  // the same at every pose of the scan
        continue;
      }
      const Eigen::Vector3d ray = cam.depth.backProject(u, v, 1.0);
      const double len = ray.norm();
      double s;
      Eigen::Vector2d zr, normal;
      if (model.rayHit(eye, R * ray / len, 0.0, &s, &zr, &normal))
        (*out)[i] = static_cast<float>(s / len);
    }
}

bool judgeable(const EdgeRegion& r) {
  return r.rect[2] - r.rect[0] >= 3 && r.rect[3] - r.rect[1] >= 3;
}

/// Calls visit(kind, outcome) for every judged pixel of `regions` (EdgeOutcomes' indices).
template <typename Visit>
void classifyPixels(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                    const std::vector<CycleCamera>& cameras,
                    const std::vector<EdgeRegion>& regions, const EstimatorConfig::Noise& noise,
                    double margin, Visit&& visit) {  // visit(camera, kind, outcome)
  std::vector<float> rendered;
  for (size_t c = 0; c < cameras.size() && c < regions.size(); ++c) {
    const CycleCamera& cam = cameras[c];
    const EdgeRegion& region = regions[c];
    if (!judgeable(region)) continue;
    const auto [u0, v0, u1, v1] = region.rect;
    const int w = u1 - u0;
    const Eigen::Isometry3d T_end_depth = T_world_end.inverse() * cam.T_world_depth;
    renderRegion(model, T_world_end, cam, region, &rendered);
    const auto at = [&](int u, int v) {
      return rendered[static_cast<size_t>(v - v0) * w + (u - u0)];
    };
    const auto judged = [&](size_t i) {
      return region.mask.empty() || (region.mask[i] & EdgeRegion::kJudged);
    };
    for (int v = v0 + 1; v < v1 - 1; ++v)
      for (int u = u0 + 1; u < u1 - 1; ++u) {
        const size_t i = static_cast<size_t>(v - v0) * w + (u - u0);
        if (!judged(i)) continue;
        const float zp = rendered[i];
        const bool hit = zp == zp;
        // Beside a model step, and the front-most rendered depth of the pixel and its four
        // neighbours.
        bool step = false;
        float front = hit ? zp : std::numeric_limits<float>::infinity();
        const int nu[4] = {u - 1, u + 1, u, u}, nv[4] = {v, v, v - 1, v + 1};
        for (int k = 0; k < 4; ++k) {
          const float zn = at(nu[k], nv[k]);
          const bool hit_n = zn == zn;
          if (hit_n != hit || (hit && std::abs(zn - zp) > kEdgeStepJump)) step = true;
          if (hit_n) front = std::min(front, zn);
        }
        // Beside a step, the pixel whose own ray meets the front-most surface of the five and
        // the one that sees past it; the rest, on the model or off it.
        const int kind = !step ? (hit ? EdgeOutcomes::kOn : EdgeOutcomes::kOff)
                         : hit && zp <= front + 0.5 * kEdgeStepJump ? EdgeOutcomes::kStepFront
                                                                       : EdgeOutcomes::kStepBack;
        const float zm = cam.image.depthAt(u, v);
        if (!(zm == zm)) {
          visit(c, kind, EdgeOutcomes::kMissing);
          continue;
        }
        if (hit || step) {
          // Behind the (front-most) model surface by more than the noise: seen through it.
          const double tol = std::max(margin, 3.0 * depthSigma(noise, front));
          visit(c, kind, zm > front + tol ? EdgeOutcomes::kOther : EdgeOutcomes::kAsModelled);
        } else {
          // The background, or a surface where the model has none.
          const Eigen::Vector3d q = T_end_depth * cam.depth.backProject(u, v, zm);
          const double d = model.coarseDistance(q.z(), std::hypot(q.x(), q.y()));
          const double tol = std::max(margin, 3.0 * depthSigma(noise, zm));
          visit(c, kind, d < tol ? EdgeOutcomes::kOther : EdgeOutcomes::kAsModelled);
        }
      }
  }
}

}  // namespace

EdgeOutcomes estimateEdgeOutcomes(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                                  const std::vector<CycleCamera>& cameras,
                                  const std::vector<EdgeRegion>& regions,
                                  const EstimatorConfig::Edges& edges,
                                  const EstimatorConfig::Noise& noise, double margin) {
  // The prior, as pseudo-pixels: the real sensor's figures (edges.*), each kind's valid pixels
  // split between as modelled and not as the configured figures say.
  std::array<std::array<double, 3>, EdgeOutcomes::kKinds> n{};
  const double w = edges.prior_pixels;
  n[EdgeOutcomes::kOn] = {w * edges.surface_invalid, w * (1 - edges.surface_invalid - edges.wrong),
                          w * edges.wrong};
  n[EdgeOutcomes::kOff] = n[EdgeOutcomes::kOn];
  n[EdgeOutcomes::kStepFront] = {w * edges.step_invalid, w * 0.5 * (1 - edges.step_invalid),
                                 w * 0.5 * (1 - edges.step_invalid)};
  n[EdgeOutcomes::kStepBack] = n[EdgeOutcomes::kStepFront];
  std::array<std::array<double, 3>, EdgeOutcomes::kKinds> counted{};
  std::vector<std::array<double, 4>> per_camera(regions.size(), {0, 0, 0, 0});
  std::vector<int> camera_pixels(regions.size(), 0);
  classifyPixels(model, T_world_end, cameras, regions, noise, margin,
                 [&](size_t c, int kind, int outcome) {
                   counted[kind][outcome] += 1.0;
                   ++camera_pixels[c];
                   // Per camera: [step pixels, of them missing, on-model pixels, of them missing].
                   auto& pc = per_camera[c];
                   const bool step =
                       kind == EdgeOutcomes::kStepFront || kind == EdgeOutcomes::kStepBack;
                   const bool missing = outcome == EdgeOutcomes::kMissing;
                   if (step) pc[0] += 1, pc[1] += missing;
                   if (kind == EdgeOutcomes::kOn) pc[2] += 1, pc[3] += missing;
                 });
  EdgeOutcomes out;
  const auto share = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    const double all = a[0] + a[1] + a[2] + b[0] + b[1] + b[2];
    return all > 0 ? (a[0] + b[0]) / all : 0.0;
  };
  out.step_missing =
      share(counted[EdgeOutcomes::kStepFront], counted[EdgeOutcomes::kStepBack]);
  out.on_missing = share(counted[EdgeOutcomes::kOn], {0, 0, 0});
  for (size_t c = 0; c < per_camera.size(); ++c) {
    const auto& pc = per_camera[c];
    out.camera_pixels.push_back(camera_pixels[c]);
    out.camera_step_missing.push_back(pc[0] > 0 ? pc[1] / pc[0] : 0.0);
    out.camera_on_missing.push_back(pc[2] > 0 ? pc[3] / pc[2] : 0.0);
  }
  for (int k = 0; k < EdgeOutcomes::kKinds; ++k)
    for (int o = 0; o < 3; ++o) n[k][o] += counted[k][o];
  for (int k = 0; k < EdgeOutcomes::kKinds; ++k) {
    const double sum = n[k][0] + n[k][1] + n[k][2];
    for (int o = 0; o < 3; ++o) out.nll[k][o] = -std::log(n[k][o] / sum);
  }
  return out;
}

double edgeNegLogLikelihood(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                            const std::vector<CycleCamera>& cameras,
                            const std::vector<EdgeRegion>& regions,
                            const EdgeOutcomes& outcomes, const EstimatorConfig::Noise& noise,
                            double margin) {
  double total = 0;
  classifyPixels(model, T_world_end, cameras, regions, noise, margin,
                 [&](size_t, int kind, int outcome) { total += outcomes.nll[kind][outcome]; });
  return total;
}

void keepChangingPixels(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                        double reach, const std::vector<CycleCamera>& cameras,
                        const EstimatorConfig::Noise& noise, double margin,
                        std::vector<EdgeRegion>* regions) {
  const Eigen::Vector3d z = T_world_end.linear().col(2);
  std::array<std::vector<float>, 3> r;
  for (size_t c = 0; c < cameras.size() && c < regions->size(); ++c) {
    EdgeRegion& region = (*regions)[c];
    region.mask.clear();
    if (!judgeable(region)) continue;
    const CycleCamera& cam = cameras[c];
    const auto [u0, v0, u1, v1] = region.rect;
    const int w = u1 - u0, h = v1 - v0;
    for (int k = 0; k < 3; ++k) {
      Eigen::Isometry3d T = T_world_end;
      T.translation() += (k - 1) * reach * z;
      renderRegion(model, T, cam, region, &r[k]);
    }
    // Changes within the scan: the rendered depth at either end of it differs from the middle's.
    std::vector<uint8_t> changes(r[1].size(), 0);
    const Eigen::Isometry3d T_end_depth = T_world_end.inverse() * cam.T_world_depth;
    for (int v = v0; v < v1; ++v)
      for (int u = u0; u < u1; ++u) {
        const size_t i = static_cast<size_t>(v - v0) * w + (u - u0);
        for (int k : {0, 2}) {
          const bool a = r[k][i] == r[k][i], b = r[1][i] == r[1][i];
          if (a != b || (a && std::abs(r[k][i] - r[1][i]) > 1e-3f)) changes[i] = 1;
        }
        // A reading near the model where it misses: its distance to the model moves with it.
        const float zm = cam.image.depthAt(u, v);
        if (!changes[i] && !(r[1][i] == r[1][i]) && zm == zm) {
          const Eigen::Vector3d q = T_end_depth * cam.depth.backProject(u, v, zm);
          const double d = model.coarseDistance(q.z(), std::hypot(q.x(), q.y()));
          if (d < std::max(margin, 3.0 * depthSigma(noise, zm)) + reach + 0.01) changes[i] = 1;
        }
      }
    // Rendered at every pose: the changing pixels (the others keep the middle's depth); judged:
    // those and their 4-neighbours (a neighbour's change can change a pixel's kind).
    region.fixed_depth = std::move(r[1]);
    region.mask.assign(changes.size(), 0);
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        const size_t i = static_cast<size_t>(v) * w + u;
        if (changes[i]) region.mask[i] |= EdgeRegion::kRendered;
        if (v < 1 || u < 1 || v >= h - 1 || u >= w - 1) continue;
        if (changes[i] || changes[i - 1] || changes[i + 1] || changes[i - w] || changes[i + w])
          region.mask[i] |= EdgeRegion::kJudged;
      }
  }
}

}  // namespace drill_pipe_pose
