// Free-space evidence of a model pose: the depth pixels where the cameras saw through it.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "drill_pipe_pose/core/estimator/seen_through.hpp"
#include "drill_pipe_pose/core/estimator/cutout.hpp"

namespace drill_pipe_pose {

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
      // (Checked before the conversion to int: a pixel far off the image, or NaN, is unseen.)
      const double uf = static_cast<double>(std::floor(fx * p.x() / p.z() + cx + 0.5f)) - off_x,
                   vf = static_cast<double>(std::floor(fy * p.y() / p.z() + cy + 0.5f)) - off_y;
      if (!(uf >= u0 && vf >= v0 && uf < u1 && vf < v1)) continue;
      const int u = static_cast<int>(uf), v = static_cast<int>(vf);
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
