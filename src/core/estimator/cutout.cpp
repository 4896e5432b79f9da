// Stage "cut-out": per-camera validation, the boxes' depth frusta, and the depth pixels that
// register into a box, in the world frame. No PCL here (kept light to compile).

#include <algorithm>
#include <cmath>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"

namespace drill_pipe_pose {

namespace {

/// The Kinect v2's amplitude effects, fitted to the real recording (kinect_noise.hpp).
const kinect_v2::AmplitudeModel kAmplitude;

/// Throws InputError naming the camera and the transform unless T is a rigid transform: finite,
/// its rotation orthonormal with determinant +1 (within 1e-3: a rotation from a quaternion
/// rounded to 4 decimals passes; a transform of arbitrary numbers does not, and its points would
/// overflow to inf and NaN), its translation within kMaxTranslation.
void checkRigid(const Eigen::Isometry3d& T, const std::string& camera, const char* name) {
  constexpr double kMaxTranslation = 1e4;  // [m] far beyond any rig's extent
  if (!T.matrix().allFinite()) fail(camera, ": ", name, " is not finite");
  const Eigen::Matrix3d R = T.linear();
  const double ortho = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(ortho <= 1e-3) || !(R.determinant() > 0))
    fail(camera, ": ", name, " is not a rigid transform (its rotation is off orthonormal by ",
         ortho, ", determinant ", R.determinant(), ")");
  if (!(T.translation().norm() <= kMaxTranslation))
    fail(camera, ": ", name, " translation ", T.translation().norm(), " m exceeds ",
         kMaxTranslation, " m");
  if (T.matrix().row(3) != Eigen::RowVector4d(0, 0, 0, 1))
    fail(camera, ": ", name, " is not a rigid transform (last row not 0 0 0 1)");
}

bool insideBox(const DetectionBox& b, const Eigen::Vector2d& uv, double margin) {
  return uv.x() >= b.x_min - margin && uv.x() <= b.x_max + margin && uv.y() >= b.y_min - margin &&
         uv.y() <= b.y_max + margin;
}

}  // namespace

CycleCamera makeCycleCamera(const SensorFrameData& frame, const Eigen::Isometry3d& T_world_depth,
                            const Eigen::Isometry3d& T_color_depth, float min_confidence,
                            const DepthCorrection& correction) {
  CycleCamera cam;
  cam.name = frame.camera;
  cam.stamp_ns = frame.stamp_ns;
  const std::string& n = frame.camera;
  cam.depth = PinholeCamera::fromCameraInfo(frame.depth_info, n + " depth_info");
  cam.color = PinholeCamera::fromCameraInfo(frame.color_info, n + " color_info");
  if (frame.depth.width == 0 || frame.depth.height == 0) fail(n, " depth: the image is empty");
  validateDepthImage(frame.depth, cam.depth, n + " depth");
  cam.image = frame.depth;  // shares the pixels
  // Corrected where read (DepthImage::depthAt): the cut-out, carving's occlusion test and the
  // seen-through pixels all see the true depth, and no pixel is copied.
  cam.image.setCorrection(correction, n + " depth");
  cam.weak_return_bias = correction.weak_return_bias;
  // An amplitude image that does not fit the depth was refused where the frame was read (the
  // message's conversion names the camera and the field); here it is simply not used.
  if (amplitudeMismatch(frame.amplitude, frame.depth, n).empty()) cam.amplitude = frame.amplitude;
  checkRigid(T_world_depth, n, "T_world_depth");
  checkRigid(T_color_depth, n, "T_color_depth");
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
  // Bounds far outside the image (a box 1e38 px wide, a tiny focal length) become ints without
  // overflow: clamped to +-1e9 px first, beyond any image.
  auto px = [](double x) { return static_cast<int>(std::clamp(x, -1e9, 1e9)); };
  (*rect)[0] = std::max(0, px(std::floor(u_min)) - 1);
  (*rect)[1] = std::max(0, px(std::floor(v_min)) - 1);
  (*rect)[2] = std::min(W, px(std::ceil(u_max)) + 2);
  (*rect)[3] = std::min(H, px(std::ceil(v_max)) + 2);
  return (*rect)[0] < (*rect)[2] && (*rect)[1] < (*rect)[3];
}

float depthSigma(const EstimatorConfig::Noise& noise, double z) {
  const double mm = kinect_v2::axialSigmaMm(z, 0.0);
  return static_cast<float>(std::max(noise.min_sigma, noise.scale * mm * 1e-3));
}

double incidenceSigma(double coefficient_mm, double range, double cos_incidence) {
  return kinect_v2::incidenceSigmaMm(coefficient_mm, range,
                                     kinect_v2::incidenceFactor(cos_incidence)) *
         1e-3;
}

void correctWeakReturns(CycleCamera* cam, const EstimatorConfig& config) {
  if (!config.noise.amplitude_model || cam->amplitude.empty()) return;
  const auto [u0, v0, u1, v1] = cam->crop;
  if (u0 >= u1 || v0 >= v1) return;
  const DepthImage& in = cam->image;
  DepthImage out = DepthImage::allocate(in.width, in.height, DepthEncoding::kF32Metres);
  const double amp_scale = config.noise.amplitude_scale;
  kinect_v2::AmplitudeModel law = kAmplitude;
  if (cam->weak_return_bias >= 0.0) law.bias_coeff = cam->weak_return_bias;  // the rig file's
  for (int v = v0; v < v1; ++v)
    for (int u = u0; u < u1; ++u) {
      const float z = in.depthAt(u, v);
      const float dn = cam->amplitude.at(u, v);
      if (!(z == z) || !(dn > 0.0f)) {  // no depth, or no amplitude: as read
        out.setDepth(u, v, z);
        continue;
      }
      // The weak-return bias of the measured amplitude, along the depth (the camera reads a
      // weak return farther), less what the depth calibration removed. A pixel moved along its
      // ray keeps its (u, v): back-projection is linear in the depth.
      const double bias = kinect_v2::weakReturnBias(law, dn / amp_scale,
                                                    config.profile_fit.bias_reference);
      out.setDepth(u, v, static_cast<float>(z - bias));
    }
  cam->image = std::move(out);
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

}  // namespace drill_pipe_pose
