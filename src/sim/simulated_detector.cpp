#include "drill_pipe_pose/sim/simulated_detector.hpp"

#include <algorithm>
#include <cmath>

#include "drill_pipe_pose/sim/random.hpp"

namespace drill_pipe_pose::sim {

std::vector<VisibleRegion> SimulatedDetector::visibleRegions(
    const Scene& scene, const SceneSnapshot& snap, const PinholeCamera& color,
    const Eigen::Isometry3d& T_world_color) const {
  std::vector<VisibleRegion> out;
  const Eigen::Isometry3d T_color_world = T_world_color.inverse();
  const int W = static_cast<int>(color.imageWidth()), H = static_cast<int>(color.imageHeight());
  const int step = std::max(1, model_.pixel_step);
  for (size_t ei = 0; ei < scene.ends.size(); ++ei) {
    const SceneEnd& e = scene.ends[ei];
    const Eigen::Isometry3d& T_world_obj = snap.T_world_object[e.object];
    // Project the region's local bounding box to get the pixel rectangle to ray cast.
    const double r = e.region_radius;
    const Eigen::AlignedBox3d local(Eigen::Vector3d(-r, -r, e.region_z_min),
                                    Eigen::Vector3d(r, r, e.region_z_max));
    double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
    bool behind = false;
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d c((i & 1) ? local.max().x() : local.min().x(),
                              (i & 2) ? local.max().y() : local.min().y(),
                              (i & 4) ? local.max().z() : local.min().z());
      const Eigen::Vector3d p = T_color_world * (T_world_obj * c);
      Eigen::Vector2d uv;
      if (p.z() < 0.05 || !color.project(p, &uv)) {
        behind = true;
        break;
      }
      u0 = std::min(u0, uv.x());
      v0 = std::min(v0, uv.y());
      u1 = std::max(u1, uv.x());
      v1 = std::max(v1, uv.y());
    }
    if (behind) continue;  // a tool joint touching the camera: not a case for this rig
    const int iu0 = std::max(0, static_cast<int>(std::floor(u0))),
              iv0 = std::max(0, static_cast<int>(std::floor(v0)));
    const int iu1 = std::min(W - 1, static_cast<int>(std::ceil(u1))),
              iv1 = std::min(H - 1, static_cast<int>(std::ceil(v1)));
    if (iu0 > iu1 || iv0 > iv1) continue;
    VisibleRegion reg;
    reg.end = ei;
    float bx0 = 1e9f, by0 = 1e9f, bx1 = -1e9f, by1 = -1e9f;
    Ray ray;
    ray.o = T_world_color.translation();
    for (int v = iv0; v <= iv1; v += step) {
      for (int u = iu0; u <= iu1; u += step) {
        const Eigen::Vector3d d_c((u + color.offsetX() - color.cx()) / color.fx(),
                                  (v + color.offsetY() - color.cy()) / color.fy(), 1.0);
        ray.d = T_world_color.linear() * d_c.normalized();
        SceneHit hit;
        if (!scene.intersect(ray, snap, nullptr, 1e-3, 1e3, &hit)) continue;
        if (hit.object != e.object) continue;
        const double z = hit.p_local.z();
        if (z < e.region_z_min - 1e-6 || z > e.region_z_max + 1e-6) continue;
        ++reg.visible_pixels;
        bx0 = std::min(bx0, u - 0.5f);
        by0 = std::min(by0, v - 0.5f);
        bx1 = std::max(bx1, u + 0.5f);
        by1 = std::max(by1, v + 0.5f);
      }
    }
    reg.visible_pixels *= step * step;
    if (reg.visible_pixels < model_.min_visible_pixels) continue;
    reg.x_min = bx0;
    reg.y_min = by0;
    reg.x_max = bx1;
    reg.y_max = by1;
    out.push_back(reg);
  }
  return out;
}

namespace {

DetectionBox jittered(const VisibleRegion& r, EndLabel label, float conf, double sigma, Rng& rng,
                      float W, float H) {
  DetectionBox b;
  b.label = label;
  b.confidence = conf;
  b.x_min = std::clamp(static_cast<float>(r.x_min + sigma * rng.normal()), -0.5f, W - 0.5f);
  b.y_min = std::clamp(static_cast<float>(r.y_min + sigma * rng.normal()), -0.5f, H - 0.5f);
  b.x_max = std::clamp(static_cast<float>(r.x_max + sigma * rng.normal()), -0.5f, W - 0.5f);
  b.y_max = std::clamp(static_cast<float>(r.y_max + sigma * rng.normal()), -0.5f, H - 0.5f);
  if (b.x_max < b.x_min + 1) b.x_max = b.x_min + 1;
  if (b.y_max < b.y_min + 1) b.y_max = b.y_min + 1;
  return b;
}

}  // namespace

std::vector<DetectionBox> SimulatedDetector::detect(const Scene& scene, const SceneSnapshot& snap,
                                                    const PinholeCamera& color,
                                                    const Eigen::Isometry3d& T_world_color,
                                                    uint64_t seed, uint64_t camera,
                                                    uint64_t frame_index) const {
  const std::vector<VisibleRegion> regions = visibleRegions(scene, snap, color, T_world_color);
  Rng rng(streamSeed(seed, kStreamDetector, camera, frame_index));
  const float W = static_cast<float>(color.imageWidth()),
              H = static_cast<float>(color.imageHeight());
  std::vector<DetectionBox> boxes;
  for (const VisibleRegion& r : regions) {
    // Draw every random number in a fixed order so one effect's switch does not shift others.
    const bool miss = rng.chance(model_.miss_probability);
    const bool swap = rng.chance(model_.swap_probability);
    const bool dup = rng.chance(model_.duplicate_probability);
    const float conf = static_cast<float>(rng.uniform(0.6, 0.99));
    const float dup_conf = static_cast<float>(rng.uniform(0.25, 0.5));
    Rng jr(rng.next());
    if (miss) continue;
    EndLabel label = scene.ends[r.end].label;
    if (swap) label = label == EndLabel::kBoxEnd ? EndLabel::kPinEnd : EndLabel::kBoxEnd;
    boxes.push_back(jittered(r, label, conf, model_.edge_jitter_px, jr, W, H));
    if (dup) boxes.push_back(jittered(r, label, dup_conf, 2.0 * model_.edge_jitter_px, jr, W, H));
  }
  if (rng.chance(model_.false_positive_probability)) {
    // A box on something else: tool-joint-like size somewhere in the image.
    DetectionBox b;
    b.label = rng.chance(0.5) ? EndLabel::kBoxEnd : EndLabel::kPinEnd;
    b.confidence = static_cast<float>(rng.uniform(0.3, 0.8));
    const float w = static_cast<float>(rng.uniform(12, 40)),
                h = static_cast<float>(rng.uniform(30, 90));
    b.x_min = static_cast<float>(rng.uniform(0, W - w));
    b.y_min = static_cast<float>(rng.uniform(0, H - h));
    b.x_max = b.x_min + w;
    b.y_max = b.y_min + h;
    boxes.push_back(b);
  }
  return boxes;
}

}  // namespace drill_pipe_pose::sim
