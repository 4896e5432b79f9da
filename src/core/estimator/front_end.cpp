// Estimator front end: configuration checks, per-camera validation, box frustum, cut-out and
// visual-hull carving. No PCL here (kept light to compile).

#include <algorithm>
#include <cmath>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/stages.hpp"

namespace drill_pipe_pose {

EstimatorMethod parseEstimatorMethod(const std::string& name, const std::string& source) {
  if (name == "ours") return EstimatorMethod::kOurs;
  if (name == "thesis_baseline") return EstimatorMethod::kThesisBaseline;
  fail(source, ": method = \"", name, "\" is not one of \"ours\", \"thesis_baseline\"");
}

const char* estimatorMethodName(EstimatorMethod m) {
  return m == EstimatorMethod::kOurs ? "ours" : "thesis_baseline";
}

namespace {

bool finiteIsometry(const Eigen::Isometry3d& T) {
  return T.matrix().allFinite();
}

bool insideBox(const DetectionBox& b, const Eigen::Vector2d& uv, double margin) {
  return uv.x() >= b.x_min - margin && uv.x() <= b.x_max + margin && uv.y() >= b.y_min - margin &&
         uv.y() <= b.y_max + margin;
}

}  // namespace

CycleCamera makeCycleCamera(const SensorFrameData& frame, const Eigen::Isometry3d& T_world_depth,
                            const Eigen::Isometry3d& T_color_depth, float min_confidence) {
  CycleCamera cam;
  cam.name = frame.camera;
  const std::string& n = frame.camera;
  cam.depth = PinholeCamera::fromCameraInfo(frame.depth_info, n + " depth_info");
  cam.color = PinholeCamera::fromCameraInfo(frame.color_info, n + " color_info");
  if (frame.depth.width == 0 || frame.depth.height == 0) fail(n, " depth: the image is empty");
  validateDepthImage(frame.depth, cam.depth, n + " depth");
  cam.image = frame.depth;
  if (!finiteIsometry(T_world_depth)) fail(n, ": T_world_depth is not finite");
  if (!finiteIsometry(T_color_depth)) fail(n, ": T_color_depth is not finite");
  cam.T_world_depth = T_world_depth;
  cam.T_color_depth = T_color_depth;
  cam.T_color_world = T_color_depth * T_world_depth.inverse();
  const double W = cam.color.imageWidth(), H = cam.color.imageHeight();
  for (size_t i = 0; i < frame.boxes.size(); ++i) {
    DetectionBox b = frame.boxes[i];
    if (!std::isfinite(b.x_min) || !std::isfinite(b.x_max) || !std::isfinite(b.y_min) ||
        !std::isfinite(b.y_max) || !(b.x_max > b.x_min) || !(b.y_max > b.y_min))
      fail(n, " boxes[", i, "]: (", b.x_min, ", ", b.y_min, ") - (", b.x_max, ", ", b.y_max,
           ") is not finite or inverted");
    if (b.x_max < -0.5 || b.y_max < -0.5 || b.x_min > W - 0.5 || b.y_min > H - 0.5)
      fail(n, " boxes[", i, "]: (", b.x_min, ", ", b.y_min, ") - (", b.x_max, ", ", b.y_max,
           ") lies outside the ", W, "x", H, " colour image");
    const int l = static_cast<int>(b.label);
    if (l < 0 || l >= kNumEnds) fail(n, " boxes[", i, "]: unknown label ", l);
    if (b.confidence < min_confidence) continue;
    cam.has_label[l] = true;
    cam.boxes.push_back(b);
  }
  if (!depthCropRect(cam, DepthCropConfig(), &cam.crop)) cam.crop = {{0, 0, 0, 0}};
  return cam;
}

bool depthRectOfBox(const CycleCamera& cam, const DetectionBox& box, double margin_px,
                    double min_range, double max_range, std::array<int, 4>* rect) {
  const Eigen::Isometry3d T_depth_color = cam.T_color_depth.inverse();
  double u_min = 1e9, v_min = 1e9, u_max = -1e9, v_max = -1e9;
  int n = 0;
  for (double u : {box.x_min - margin_px, box.x_max + margin_px})
    for (double v : {box.y_min - margin_px, box.y_max + margin_px})
      for (double z : {min_range, max_range}) {
        Eigen::Vector2d uv;
        if (!cam.depth.project(T_depth_color * cam.color.backProject(u, v, z), &uv)) continue;
        ++n;
        u_min = std::min(u_min, uv.x());
        u_max = std::max(u_max, uv.x());
        v_min = std::min(v_min, uv.y());
        v_max = std::max(v_max, uv.y());
      }
  if (n == 0) return false;
  const int W = static_cast<int>(cam.depth.imageWidth()),
            H = static_cast<int>(cam.depth.imageHeight());
  (*rect)[0] = std::max(0, static_cast<int>(std::floor(u_min)) - 1);
  (*rect)[1] = std::max(0, static_cast<int>(std::floor(v_min)) - 1);
  (*rect)[2] = std::min(W, static_cast<int>(std::ceil(u_max)) + 2);
  (*rect)[3] = std::min(H, static_cast<int>(std::ceil(v_max)) + 2);
  return (*rect)[0] < (*rect)[2] && (*rect)[1] < (*rect)[3];
}

float depthSigma(const EstimatorConfig::Noise& noise, double z) {
  const double mm = 1.5 - 0.5 * z + 0.3 * z * z;
  return static_cast<float>(std::max(noise.min_sigma, noise.scale * mm * 1e-3));
}

double incidenceSigma(double coefficient_mm, double range, double cos_incidence) {
  constexpr double kMaxIncidence = 84.0 * M_PI / 180.0;  // as the simulator's sensor model
  const double th = std::min(std::acos(std::clamp(cos_incidence, 0.0, 1.0)), kMaxIncidence);
  const double g = th / (M_PI_2 - th);
  return coefficient_mm * 1e-3 * std::pow(range, 1.5) * g * g;
}

void cutOutCamera(const CycleCamera& cam, uint16_t camera_index, const EstimatorConfig& config,
                  std::array<std::vector<CloudPoint>, kNumEnds>* out) {
  const DepthProjector projector(cam.depth);
  const Eigen::Matrix3f R_cd = cam.T_color_depth.linear().cast<float>();
  const Eigen::Vector3f t_cd = cam.T_color_depth.translation().cast<float>();
  const Eigen::Matrix3f R_wd = cam.T_world_depth.linear().cast<float>();
  const Eigen::Vector3f t_wd = cam.T_world_depth.translation().cast<float>();
  const Eigen::Vector3f zone_min = config.work_zone.min.cast<float>();
  const Eigen::Vector3f zone_max = config.work_zone.max.cast<float>();
  const float fx = cam.color.fx(), fy = cam.color.fy();
  const float cx = cam.color.cx() - cam.color.offsetX(), cy = cam.color.cy() - cam.color.offsetY();
  const double m = config.cutout.box_margin_px;
  const float zmin = config.cutout.min_range, zmax = config.cutout.max_range;
  const float jump = static_cast<float>(config.cutout.edge_jump);
  const int W = static_cast<int>(cam.image.width), H = static_cast<int>(cam.image.height);
  for (size_t k = 0; k < cam.boxes.size(); ++k) {
    const DetectionBox& b = cam.boxes[k];
    std::array<int, 4> r;
    if (!depthRectOfBox(cam, b, m, zmin, zmax, &r)) continue;
    const int label = static_cast<int>(b.label);
    std::vector<CloudPoint>& dst = (*out)[label];
    projector.forEachPoint(
        cam.image, r[0], r[1], r[2], r[3], [&](int u, int v, const Eigen::Vector3f& p) {
          if (p.z() < zmin || p.z() > zmax) return;
          if (jump > 0.0f) {
            // Depth edge: mixed (flying) pixels and grazing silhouette pixels, the least
            // reliable depths, biased toward the background.
            const float lim = std::max(jump, 4.0f * depthSigma(config.noise, p.z()));
            const int nu[4] = {u - 1, u + 1, u, u}, nv[4] = {v, v, v - 1, v + 1};
            for (int q = 0; q < 4; ++q) {
              if (nu[q] < 0 || nv[q] < 0 || nu[q] >= W || nv[q] >= H) continue;
              const float zn = cam.image.depthAt(nu[q], nv[q]);
              if (zn == zn && std::abs(zn - p.z()) > lim) return;
            }
          }
          const Eigen::Vector3f pc = R_cd * p + t_cd;
          if (!(pc.z() > 0.0f)) return;
          const Eigen::Vector2d uv(fx * pc.x() / pc.z() + cx, fy * pc.y() / pc.z() + cy);
          if (!insideBox(b, uv, m)) return;
          for (size_t j = 0; j < k; ++j)  // emitted by an earlier box already
            if (cam.boxes[j].label == b.label && insideBox(cam.boxes[j], uv, m)) return;
          const Eigen::Vector3f pw = R_wd * p + t_wd;
          if ((pw.array() < zone_min.array()).any() || (pw.array() > zone_max.array()).any())
            return;
          dst.push_back({pw, depthSigma(config.noise, p.z()), camera_index});
        });
  }
}

std::vector<CloudPoint> carve(const std::vector<CloudPoint>& points, EndLabel label,
                              const std::vector<CycleCamera>& cameras,
                              const EstimatorConfig::Carving& config) {
  const int l = static_cast<int>(label);
  struct Judge {
    Eigen::Matrix3f R;
    Eigen::Vector3f t;
    float fx, fy, cx, cy, w, h;
    std::vector<const DetectionBox*> boxes;
    // Where each box's own cut-out points lie in the world (their bounding box): the camera
    // votes against a point only within carving.box_reach of one of them.
    std::vector<Eigen::AlignedBox3f> reach;
    // The depth image, to tell whether the camera sees the point at all.
    Eigen::Matrix3f R_d;
    Eigen::Vector3f t_d;
    float dfx, dfy, dcx, dcy;  // full-sensor principal point
    int off_x, off_y;          // the delivered image's offset in the sensor (roi)
    const DepthImage* depth;
    std::array<int, 4> crop;  // depth pixels the occlusion test may read (CycleCamera::crop)
  };
  std::vector<Judge> judges(cameras.size());
  std::vector<bool> can_judge(cameras.size(), false);
  for (size_t c = 0; c < cameras.size(); ++c) {
    const CycleCamera& cam = cameras[c];
    if (!cam.has_label[l]) continue;
    can_judge[c] = true;
    Judge& j = judges[c];
    j.R = cam.T_color_world.linear().cast<float>();
    j.t = cam.T_color_world.translation().cast<float>();
    j.fx = cam.color.fx();
    j.fy = cam.color.fy();
    j.cx = cam.color.cx() - cam.color.offsetX();
    j.cy = cam.color.cy() - cam.color.offsetY();
    j.w = cam.color.imageWidth();
    j.h = cam.color.imageHeight();
    const Eigen::Isometry3d T_depth_world = cam.T_world_depth.inverse();
    j.R_d = T_depth_world.linear().cast<float>();
    j.t_d = T_depth_world.translation().cast<float>();
    j.dfx = cam.depth.fx();
    j.dfy = cam.depth.fy();
    j.dcx = cam.depth.cx();
    j.dcy = cam.depth.cy();
    j.off_x = static_cast<int>(cam.depth.offsetX());
    j.off_y = static_cast<int>(cam.depth.offsetY());
    j.depth = &cam.image;
    j.crop = cam.crop;
    for (const auto& b : cam.boxes)
      if (b.label == label) j.boxes.push_back(&b);
    j.reach.assign(j.boxes.size(), Eigen::AlignedBox3f());
  }
  const float margin = config.margin_px;
  auto inBox = [margin](const DetectionBox& b, float u, float v) {
    return u >= b.x_min - margin && u <= b.x_max + margin && v >= b.y_min - margin &&
           v <= b.y_max + margin;
  };
  // Pixel of a world point in camera j's colour image; false when behind it or outside.
  auto project = [](const Judge& j, const Eigen::Vector3f& pw, float* u, float* v) {
    const Eigen::Vector3f pc = j.R * pw + j.t;
    if (!(pc.z() > 0.0f)) return false;
    *u = j.fx * pc.x() / pc.z() + j.cx;
    *v = j.fy * pc.y() / pc.z() + j.cy;
    return !(*u < -0.5f || *v < -0.5f || *u > j.w - 0.5f || *v > j.h - 0.5f);
  };
  const bool reach_on = config.box_reach > 0;
  if (reach_on)
    for (const CloudPoint& p : points) {
      if (p.camera >= cameras.size() || !can_judge[p.camera]) continue;
      Judge& j = judges[p.camera];
      float u, v;
      if (!project(j, p.p_world, &u, &v)) continue;
      for (size_t k = 0; k < j.boxes.size(); ++k)
        if (inBox(*j.boxes[k], u, v)) j.reach[k].extend(p.p_world);
    }
  const float reach2 = static_cast<float>(config.box_reach * config.box_reach);
  auto withinReach = [&](const Judge& j, const Eigen::Vector3f& pw) {
    for (const auto& r : j.reach)
      if (!r.isEmpty() && r.squaredExteriorDistance(pw) <= reach2) return true;
    return false;
  };
  // Something nearer than the point on the camera's ray (its depth pixel, where delivered, is
  // closer by more than occlusion_margin): the camera cannot see the point, and does not vote.
  auto occluded = [&](const Judge& j, const Eigen::Vector3f& pw) {
    const Eigen::Vector3f pd = j.R_d * pw + j.t_d;
    if (!(pd.z() > 0.0f)) return false;
    // Rounded in sensor pixels, then shifted: the same pixel with full and cropped depth.
    const int u = static_cast<int>(std::round(j.dfx * pd.x() / pd.z() + j.dcx)) - j.off_x,
              v = static_cast<int>(std::round(j.dfy * pd.y() / pd.z() + j.dcy)) - j.off_y;
    if (u < j.crop[0] || v < j.crop[1] || u >= j.crop[2] || v >= j.crop[3]) return false;
    const float z = j.depth->depthAt(static_cast<uint32_t>(u), static_cast<uint32_t>(v));
    return z > 0.0f && z < pd.z() - static_cast<float>(config.occlusion_margin);
  };
  std::vector<CloudPoint> kept;
  kept.reserve(points.size());
  for (const CloudPoint& p : points) {
    int voters = 1, inside = 1;
    for (size_t c = 0; c < cameras.size(); ++c) {
      if (c == p.camera || !can_judge[c]) continue;
      const Judge& j = judges[c];
      float u, v;
      if (!project(j, p.p_world, &u, &v)) continue;
      if (config.occlusion_margin > 0 && occluded(j, p.p_world)) continue;
      bool in = false;
      for (const DetectionBox* b : j.boxes) in = in || inBox(*b, u, v);
      // Outside every box: a vote against only from a detection near the point.
      if (!in && reach_on && !withinReach(j, p.p_world)) continue;
      ++voters;
      if (in) ++inside;
    }
    if (voters < config.min_cameras ||
        (inside >= config.min_cameras && inside >= config.vote_fraction * voters))
      kept.push_back(p);
  }
  return kept;
}

}  // namespace drill_pipe_pose
