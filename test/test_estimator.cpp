// Estimator pipeline (issue 4) on synthetic data: an analytic ray caster renders Kinect-v2-like
// depth images of a tool joint (a body of revolution from toolJointProfile) plus clutter and a
// ground plane; detector boxes come from projecting the joint into the colour image. Seeds are
// printed on failure (SCOPED_TRACE).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <random>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"
#include "drill_pipe_pose/core/estimator/stages.hpp"
#include "drill_pipe_pose/core/estimator/temporal_filter.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"
#include "drill_pipe_pose/core/metrics.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

using namespace drill_pipe_pose;

namespace {

constexpr double kDeg = M_PI / 180.0;

CameraInfoData depthInfo() {
  CameraInfoData c;
  c.width = 512;
  c.height = 424;
  c.distortion_model = "plumb_bob";
  c.D = {0, 0, 0, 0, 0};
  c.K = {365.4, 0, 260.9, 0, 365.4, 205.6, 0, 0, 1};
  c.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.P = {365.4, 0, 260.9, 0, 0, 365.4, 205.6, 0, 0, 0, 1, 0};
  return c;
}

CameraInfoData colorInfo() {
  CameraInfoData c = depthInfo();
  c.width = 960;
  c.height = 540;
  c.K = {540.7, 0, 479.75, 0, 540.7, 269.75, 0, 0, 1};
  c.P = {540.7, 0, 479.75, 0, 0, 540.7, 269.75, 0, 0, 0, 1, 0};
  return c;
}

/// Optical frame (z forward, x right, y down) at `eye` looking at `target`.
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ());
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();
  x.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << x, z.cross(x), z;
  T.translation() = eye;
  return T;
}

/// A tool joint in the scene.
struct Joint {
  EndLabel label;
  Eigen::Isometry3d T_world_end;
  ToolJointDimensions dims;  ///< rendered geometry (may be worn)
  std::vector<ProfilePoint> profile;
};

/// A vertical clutter cylinder.
struct Post {
  Eigen::Vector2d xy;
  double radius, z0, z1;
};

struct Scene {
  std::vector<Joint> joints;
  std::vector<Post> posts;
  bool ground = true;
};

/// Smallest t > 0 where the ray o + t d (end frame) hits the surface of revolution of `profile`.
double hitProfile(const std::vector<ProfilePoint>& prof, const Eigen::Vector3d& o,
                  const Eigen::Vector3d& d) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < prof.size(); ++i) {
    const ProfilePoint& a = prof[i];
    const ProfilePoint& b = prof[(i + 1) % prof.size()];
    if (std::abs(b.z - a.z) < 1e-12) {  // annulus in the plane z = a.z
      if (std::abs(d.z()) < 1e-12) continue;
      const double t = (a.z - o.z()) / d.z();
      if (t <= 1e-6 || t >= best) continue;
      const Eigen::Vector3d p = o + t * d;
      const double r = std::hypot(p.x(), p.y());
      if (r >= std::min(a.r, b.r) && r <= std::max(a.r, b.r)) best = t;
      continue;
    }
    const double k = (b.r - a.r) / (b.z - a.z), c0 = a.r - k * a.z;  // r = c0 + k z
    const double A = d.x() * d.x() + d.y() * d.y() - k * k * d.z() * d.z();
    const double B = 2 * (o.x() * d.x() + o.y() * d.y() - k * d.z() * (c0 + k * o.z()));
    const double C = o.x() * o.x() + o.y() * o.y() - (c0 + k * o.z()) * (c0 + k * o.z());
    double roots[2];
    int n = 0;
    if (std::abs(A) < 1e-12) {
      if (std::abs(B) > 1e-12) roots[n++] = -C / B;
    } else {
      const double disc = B * B - 4 * A * C;
      if (disc < 0) continue;
      const double s = std::sqrt(disc);
      roots[n++] = (-B - s) / (2 * A);
      roots[n++] = (-B + s) / (2 * A);
    }
    for (int j = 0; j < n; ++j) {
      const double t = roots[j];
      if (t <= 1e-6 || t >= best) continue;
      const double z = o.z() + t * d.z();
      if (z < std::min(a.z, b.z) || z > std::max(a.z, b.z) || c0 + k * z < 0) continue;
      best = t;
    }
  }
  return best;
}

double hitScene(const Scene& s, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double best = std::numeric_limits<double>::infinity();
  if (s.ground && d.z() < -1e-9) best = -o.z() / d.z();
  for (const Joint& j : s.joints) {
    const Eigen::Isometry3d T_end_world = j.T_world_end.inverse();
    const Eigen::Vector3d oe = T_end_world * o, de = T_end_world.linear() * d;
    // Bounding sphere around the joint's middle.
    const Eigen::Vector3d c(0, 0, -0.3);
    const Eigen::Vector3d oc = oe - c;
    const double bb = oc.dot(de), cc = oc.squaredNorm() - 0.7 * 0.7;
    if (bb * bb - cc < 0) continue;
    best = std::min(best, hitProfile(j.profile, oe, de));
  }
  for (const Post& p : s.posts) {
    const Eigen::Vector2d oc(o.x() - p.xy.x(), o.y() - p.xy.y()), dd(d.x(), d.y());
    const double A = dd.squaredNorm(), B = 2 * oc.dot(dd),
                 C = oc.squaredNorm() - p.radius * p.radius;
    const double disc = B * B - 4 * A * C;
    if (A < 1e-12 || disc < 0) continue;
    const double t = (-B - std::sqrt(disc)) / (2 * A);
    const double z = o.z() + t * d.z();
    if (t > 0 && z >= p.z0 && z <= p.z1) best = std::min(best, t);
  }
  return best;
}

struct SimCamera {
  std::string name;
  Eigen::Isometry3d T_world_color;
  Eigen::Isometry3d T_color_depth;
  Eigen::Isometry3d T_world_depth() const { return T_world_color * T_color_depth.inverse(); }
};

struct RenderOptions {
  double noise_scale = 0.0;  ///< x Fankhauser sigma
  double box_jitter_px = 0.0;
  uint32_t seed = 1;
  bool swap_labels = false;
};

/// Renders one camera: depth image (16UC1) and a box per visible joint.
CameraInput render(const Scene& scene, const SimCamera& cam, const RenderOptions& opt,
                   std::mt19937* rng) {
  CameraInput in;
  in.frame.camera = cam.name;
  in.frame.depth_info = depthInfo();
  in.frame.color_info = colorInfo();
  in.T_color_depth = cam.T_color_depth;
  in.T_world_depth = cam.T_world_depth();
  const PinholeCamera depth = PinholeCamera::fromCameraInfo(in.frame.depth_info, "sim");
  const PinholeCamera color = PinholeCamera::fromCameraInfo(in.frame.color_info, "sim");
  in.frame.depth = DepthImage::allocate(512, 424, DepthEncoding::kU16Millimetres);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Isometry3d T_wd = in.T_world_depth;
  for (uint32_t v = 0; v < 424; ++v)
    for (uint32_t u = 0; u < 512; ++u) {
      const Eigen::Vector3d ray = depth.backProject(u, v, 1.0);
      const Eigen::Vector3d dw = (T_wd.linear() * ray).normalized();
      const double t = hitScene(scene, T_wd.translation(), dw);
      if (!std::isfinite(t)) continue;
      double z = t / ray.norm();
      if (z > 12.0) continue;
      if (opt.noise_scale > 0)
        z += opt.noise_scale * (1.5 - 0.5 * z + 0.3 * z * z) * 1e-3 * gauss(*rng);
      in.frame.depth.setDepth(u, v, static_cast<float>(z));
    }
  const Eigen::Isometry3d T_color_world = cam.T_world_color.inverse();
  for (const Joint& j : scene.joints) {
    const double zlo =
        -(j.label == EndLabel::kBoxEnd ? j.dims.box_tong_length : j.dims.pin_tong_length) -
        j.dims.taperLength();
    const double zhi = j.label == EndLabel::kBoxEnd ? 0.0 : j.dims.pin_length;
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const auto& s : sampleProfileSurface(j.profile, 0.01, 1, true)) {
      if (s.p.z() < zlo - 1e-6 || s.p.z() > zhi + 1e-6) continue;
      Eigen::Vector2d uv;
      if (!color.project(T_color_world * (j.T_world_end * s.p.cast<double>()), &uv)) continue;
      x0 = std::min(x0, uv.x());
      x1 = std::max(x1, uv.x());
      y0 = std::min(y0, uv.y());
      y1 = std::max(y1, uv.y());
    }
    if (x1 < 0 || y1 < 0 || x0 > 959 || y0 > 539) continue;
    DetectionBox b;
    b.label = opt.swap_labels ? static_cast<EndLabel>(1 - static_cast<int>(j.label)) : j.label;
    b.confidence = 0.9f;
    std::normal_distribution<double> jit(0.0, opt.box_jitter_px);
    const double jx0 = opt.box_jitter_px > 0 ? jit(*rng) : 0,
                 jx1 = opt.box_jitter_px > 0 ? jit(*rng) : 0;
    const double jy0 = opt.box_jitter_px > 0 ? jit(*rng) : 0,
                 jy1 = opt.box_jitter_px > 0 ? jit(*rng) : 0;
    b.x_min = std::max(0.0, x0 + jx0);
    b.x_max = std::min(959.0, x1 + jx1);
    b.y_min = std::max(0.0, y0 + jy0);
    b.y_max = std::min(539.0, y1 + jy1);
    in.frame.boxes.push_back(b);
  }
  return in;
}

/// Six cameras around `centre` on a circle of `radius` at `height` (thesis-like rig).
std::vector<SimCamera> ring(const Eigen::Vector3d& centre, double radius, double height,
                            int n = 6) {
  std::vector<SimCamera> cams;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n + 0.3;
    SimCamera c;
    c.name = "cam" + std::to_string(i + 1);
    const Eigen::Vector3d eye =
        centre + Eigen::Vector3d(radius * std::cos(a), radius * std::sin(a), 0);
    c.T_world_color = lookAt(Eigen::Vector3d(eye.x(), eye.y(), height), centre);
    c.T_color_depth = Eigen::Isometry3d::Identity();
    c.T_color_depth.translation() = Eigen::Vector3d(0.0515, 0.0, 0.001);  // as read from TF
    cams.push_back(c);
  }
  return cams;
}

Joint makeJoint(EndLabel label, const Eigen::Isometry3d& T, const ToolJointDimensions& dims = {}) {
  return {label, canonicalize(T), dims, toolJointProfile(label, dims)};
}

Eigen::Isometry3d poseAt(const Eigen::Vector3d& origin, const Eigen::Vector3d& z) {
  return canonicalPose(origin, z);
}

std::vector<CameraInput> renderAll(const Scene& scene, const std::vector<SimCamera>& cams,
                                   const RenderOptions& opt) {
  std::mt19937 rng(opt.seed);
  std::vector<CameraInput> out;
  for (const auto& c : cams) out.push_back(render(scene, c, opt, &rng));
  return out;
}

/// Every camera's CycleCamera and cut-out points (per label), as a cycle makes them.
void cutOutAll(const std::vector<CameraInput>& inputs, const EstimatorConfig& cfg,
               std::vector<CycleCamera>* cc, std::array<std::vector<CloudPoint>, kNumEnds>* raw) {
  for (size_t i = 0; i < inputs.size(); ++i) {
    cc->push_back(
        makeCycleCamera(inputs[i].frame, inputs[i].T_world_depth, inputs[i].T_color_depth, 0));
    cutOutCamera(cc->back(), static_cast<uint16_t>(i), cfg, raw);
  }
}

EstimatorConfig testConfig() {
  EstimatorConfig c;
  c.work_zone.min = Eigen::Vector3d(-20, -20, 0.02);  // drops the ground
  c.work_zone.max = Eigen::Vector3d(20, 20, 6);
  // These tests judge what one cycle's fits publish; holding a new track's first pose until the
  // next fit agrees is the temporal filter's own (TemporalFilter tests,
  // PoseEstimator.ANewTracksFirstPoseIsHeldUntilTheNextAgrees).
  c.temporal.confirm_start = false;
  return c;
}

std::string describe(const EndEstimate& e) {
  std::ostringstream s;
  s << labelName(e.label) << " valid=" << e.valid << " reason='" << e.reason
    << "' points=" << e.points << " residual=" << e.residual * 1000
    << "mm corrected=" << e.label_corrected << " pos=" << e.T_world_end.translation().transpose()
    << " z=" << e.T_world_end.linear().col(2).transpose();
  return s.str();
}

/// Mahalanobis distance^2 of the position error under the estimate's position covariance.
double positionMahalanobis2(const EndEstimate& e, const Eigen::Isometry3d& truth) {
  const Eigen::Vector3d d = e.T_world_end.translation() - truth.translation();
  return d.dot(e.covariance.block<3, 3>(0, 0).ldlt().solve(d));
}

}  // namespace

// ---------------------------------------------------------------------------------------------

TEST(EstimatorConfig, RejectsBadKeysByName) {
  EXPECT_NO_THROW(validateConfig(EstimatorConfig()));
  auto expectRejected = [](const EstimatorConfig& c, const std::string& key) {
    try {
      validateConfig(c);
      FAIL() << "accepted a bad " << key;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  // One bad key per case: the error names it.
  const std::vector<std::pair<std::function<void(EstimatorConfig&)>, std::string>> cases = {
      {[](EstimatorConfig& c) { c.carving.min_cameras = 0; }, "carving/min_cameras"},
      {[](EstimatorConfig& c) { c.tracking.redecide_every = 0; }, "tracking/redecide_every"},
      {[](EstimatorConfig& c) { c.threads = 0; }, "threads"},
      {[](EstimatorConfig& c) { c.tracking.max_offset = -0.1; }, "tracking/max_offset"},
      {[](EstimatorConfig& c) { c.profile_fit.coarse_points = 5; }, "profile_fit/coarse_points"},
      {[](EstimatorConfig& c) { c.free_space.min_axial_contrast = std::nan(""); },
       "free_space/min_axial_contrast"},
      {[](EstimatorConfig& c) { c.carving.occlusion_margin = -0.1; }, "carving/occlusion_margin"},
      {[](EstimatorConfig& c) { c.carving.box_reach = std::nan(""); }, "carving/box_reach"},
      {[](EstimatorConfig& c) { c.temporal.confirmations = -1; }, "temporal/confirmations"},
      {[](EstimatorConfig& c) { c.profile_fit.silhouette_min_inlier_fraction = 1.5; },
       "profile_fit/silhouette_min_inlier_fraction"},
      {[](EstimatorConfig& c) { c.profile_fit.incidence_noise = -0.1; },
       "profile_fit/incidence_noise"},
      {[](EstimatorConfig& c) { c.profile_fit.support_clearance = -0.01; },
       "profile_fit/support_clearance"},
      {[](EstimatorConfig& c) { c.instances.radius_difference = -0.001; },
       "instances/radius_difference"},
      {[](EstimatorConfig& c) { c.instances.cluster_tolerance = 0; },
       "instances/cluster_tolerance"},
      {[](EstimatorConfig& c) { c.instances.min_decisions = 0; }, "instances/min_decisions"},
  };
  for (const auto& [mutate, key] : cases) {
    EstimatorConfig c;
    mutate(c);
    expectRejected(c, key);
  }
  EXPECT_THROW(parseEstimatorMethod("icp", "test"), InputError);
  EXPECT_EQ(parseEstimatorMethod("thesis_baseline", "test"), EstimatorMethod::kThesisBaseline);
}

TEST(CutOut, KeepsOnlyPixelsRegisteringIntoTheBoxAndCropIsEquivalent) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({5, 5, 1.2}, {0, 0, 1})));
  const auto cams = ring({5, 5, 1.0}, 5.5, 4.5);
  const auto inputs = renderAll(scene, cams, {});
  const CameraInput& in = inputs[0];
  ASSERT_EQ(in.frame.boxes.size(), 1u);
  EstimatorConfig cfg;
  cfg.cutout.box_margin_px = 0.0;
  const CycleCamera cam = makeCycleCamera(in.frame, in.T_world_depth, in.T_color_depth, 0.0f);
  std::array<std::vector<CloudPoint>, kNumEnds> out;
  cutOutCamera(cam, 0, cfg, &out);
  ASSERT_GT(out[0].size(), 100u);
  EXPECT_TRUE(out[1].empty());
  // Brute force over the full image: the same number of in-box pixels.
  const DepthToColorRegistration reg(cam.depth, cam.color, cam.T_color_depth);
  const DepthProjector proj(cam.depth);
  const DetectionBox& b = in.frame.boxes[0];
  size_t brute = 0;
  for (const auto& p : proj.allPoints(in.frame.depth)) {
    Eigen::Vector2d uv;
    Eigen::Vector2d dpx(0, 0);
    if (!cam.depth.project(p.cast<double>(), &dpx)) continue;
    if (!reg.registerPixel(std::round(dpx.x()), std::round(dpx.y()), p.z(), &uv)) continue;
    if (uv.x() >= b.x_min && uv.x() <= b.x_max && uv.y() >= b.y_min && uv.y() <= b.y_max) ++brute;
  }
  EXPECT_EQ(out[0].size(), brute);
  // Every point registers into the box.
  const Eigen::Isometry3d T_color_world = cam.T_color_world;
  for (const auto& p : out[0]) {
    Eigen::Vector2d uv;
    ASSERT_TRUE(cam.color.project(T_color_world * p.p_world.cast<double>(), &uv));
    EXPECT_GE(uv.x(), b.x_min - 0.01);
    EXPECT_LE(uv.x(), b.x_max + 0.01);
  }
  // Cropped depth (roi) around the object gives the same points.
  SensorFrameData cropped = in.frame;
  ImageRoi roi{150, 100, 200, 220};
  cropped.depth_info.roi = roi;
  cropped.depth = DepthImage::allocate(roi.width, roi.height, DepthEncoding::kU16Millimetres);
  for (uint32_t v = 0; v < roi.height; ++v)
    for (uint32_t u = 0; u < roi.width; ++u)
      cropped.depth.setDepth(u, v, in.frame.depth.depthAt(u + roi.x_offset, v + roi.y_offset));
  const CycleCamera cc = makeCycleCamera(cropped, in.T_world_depth, in.T_color_depth, 0.0f);
  std::array<std::vector<CloudPoint>, kNumEnds> out2;
  cutOutCamera(cc, 0, cfg, &out2);
  ASSERT_EQ(out2[0].size(), out[0].size());
  for (size_t i = 0; i < out[0].size(); ++i)
    EXPECT_LT((out[0][i].p_world - out2[0][i].p_world).norm(), 1e-5f);
}

TEST(CutOut, MeasuredAmplitudeTakesTheWeakReturnBiasOutOfTheDepth) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({5, 5, 1.2}, {0, 0, 1})));
  const auto cams = ring({5, 5, 1.0}, 5.5, 4.5);
  const auto inputs = renderAll(scene, cams, {});
  const CameraInput& in = inputs[0];
  EstimatorConfig cfg;
  cfg.noise.amplitude_model = true;
  const CycleCamera plain = makeCycleCamera(in.frame, in.T_world_depth, in.T_color_depth, 0.0f);
  std::array<std::vector<CloudPoint>, kNumEnds> without;
  cutOutCamera(plain, 0, cfg, &without);
  ASSERT_GT(without[0].size(), 100u);
  // A bright return (a = 0.1 /m^2, 2 m away at reflectivity 0.4) reads nearer than the
  // calibrated reference: the cut-out moves it back along its ray by the model's bias.
  SensorFrameData f = in.frame;
  f.amplitude = AmplitudeImage::allocate(f.depth.width, f.depth.height);
  const float a = 0.1f;
  for (uint32_t v = 0; v < f.depth.height; ++v)
    for (uint32_t u = 0; u < f.depth.width; ++u)
      f.amplitude.set(u, v, a * static_cast<float>(cfg.noise.amplitude_scale));
  const CycleCamera bright = makeCycleCamera(f, in.T_world_depth, in.T_color_depth, 0.0f);
  CycleCamera corrected = bright;
  correctWeakReturns(&corrected, cfg);
  std::array<std::vector<CloudPoint>, kNumEnds> with;
  cutOutCamera(corrected, 0, cfg, &with);
  ASSERT_EQ(with[0].size(), without[0].size());
  const kinect_v2::AmplitudeModel model;
  const double bias = kinect_v2::weakReturnBias(model, a, cfg.profile_fit.bias_reference);
  ASSERT_LT(bias, -0.02);  // about 28 mm nearer
  const Eigen::Vector3f eye = in.T_world_depth.translation().cast<float>();
  for (size_t i = 0; i < with[0].size(); i += 37) {
    const Eigen::Vector3f d = with[0][i].p_world - without[0][i].p_world;
    const Eigen::Vector3f ray = (without[0][i].p_world - eye).normalized();
    EXPECT_GT(d.dot(ray), 0.0f) << "point " << i << " moved toward the camera";
    // Along the ray by -bias / cos(the ray's angle to the optical axis), within a few percent.
    EXPECT_NEAR(d.norm(), -bias, 0.1 * -bias) << "point " << i;
    // The same noise model, at the corrected depth (28 mm farther: within 1 %).
    EXPECT_NEAR(with[0][i].sigma, without[0][i].sigma, 0.01 * without[0][i].sigma);
  }
  // Every reader of the depth sees the corrected depth: a pixel's depth is nearer by the bias.
  int read = 0;
  for (int v = corrected.crop[1]; v < corrected.crop[3]; v += 3)
    for (int u = corrected.crop[0]; u < corrected.crop[2]; u += 3) {
      const float z = bright.image.depthAt(u, v);
      if (!(z == z)) continue;
      EXPECT_NEAR(corrected.image.depthAt(u, v), z - bias, 1e-5) << "pixel " << u << ", " << v;
      ++read;
    }
  EXPECT_GT(read, 100);
  // A camera whose rig file carries its own weak-return B is corrected with it.
  DepthCorrection own;
  own.weak_return_bias = 2.0 * model.bias_coeff;
  CycleCamera own_law = makeCycleCamera(f, in.T_world_depth, in.T_color_depth, 0.0f, own);
  correctWeakReturns(&own_law, cfg);
  int read_own = 0;
  for (int v = own_law.crop[1]; v < own_law.crop[3]; v += 3)
    for (int u = own_law.crop[0]; u < own_law.crop[2]; u += 3) {
      const float z = bright.image.depthAt(u, v);
      if (!(z == z)) continue;
      EXPECT_NEAR(own_law.image.depthAt(u, v), z - 2.0 * bias, 1e-5) << "pixel " << u << ", " << v;
      ++read_own;
    }
  EXPECT_GT(read_own, 100);
  // With the amplitude model off (the default), the amplitude changes nothing.
  cfg.noise.amplitude_model = false;
  CycleCamera untouched = bright;
  correctWeakReturns(&untouched, cfg);
  EXPECT_EQ(untouched.image.data, bright.image.data);
  std::array<std::vector<CloudPoint>, kNumEnds> off;
  cutOutCamera(untouched, 0, cfg, &off);
  ASSERT_EQ(off[0].size(), without[0].size());
  for (size_t i = 0; i < off[0].size(); ++i)
    EXPECT_EQ(off[0][i].p_world, without[0][i].p_world) << "point " << i;
  // An amplitude image of another size is not used.
  f.amplitude = AmplitudeImage::allocate(f.depth.width - 1, f.depth.height);
  const CycleCamera other = makeCycleCamera(f, in.T_world_depth, in.T_color_depth, 0.0f);
  EXPECT_TRUE(other.amplitude.empty());
}

TEST(Carving, RemovesClutterSeenInsideOneCameraBoxOnly) {
  Scene scene;
  const Eigen::Vector3d c(5, 5, 1.2);
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt(c, {0, 0, 1})));
  auto cams = ring({5, 5, 1.0}, 5.5, 4.5);
  // A post 0.35 m behind the joint as cam1 sees it.
  const Eigen::Vector3d view = (c - cams[0].T_world_color.translation());
  const Eigen::Vector2d dir = Eigen::Vector2d(view.x(), view.y()).normalized();
  scene.posts.push_back({Eigen::Vector2d(c.x(), c.y()) + 0.35 * dir, 0.06, 0.0, 2.0});
  const auto inputs = renderAll(scene, cams, {});
  EstimatorConfig cfg = testConfig();
  std::vector<CycleCamera> cc;
  std::array<std::vector<CloudPoint>, kNumEnds> raw;
  cutOutAll(inputs, cfg, &cc, &raw);
  auto axisDist = [&](const Eigen::Vector3f& p) {
    return std::hypot(p.x() - c.x(), p.y() - c.y());
  };
  size_t clutter_before = 0;
  for (const auto& p : raw[0]) clutter_before += axisDist(p.p_world) > 0.12;
  const auto kept = carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving);
  size_t clutter_after = 0, pipe_after = 0, pipe_before = raw[0].size() - clutter_before;
  for (const auto& p : kept) {
    clutter_after += axisDist(p.p_world) > 0.12;
    pipe_after += axisDist(p.p_world) <= 0.12;
  }
  EXPECT_GT(clutter_before, 20u);
  EXPECT_EQ(clutter_after, 0u);
  EXPECT_GT(pipe_after, 0.9 * pipe_before);
}

// Camera k's detector misses the box end in front of it: of its box-end boxes, only the one
// around `keep`'s projection is left.
void keepOnlyBoxEndBoxAround(std::vector<CameraInput>* inputs, const std::vector<SimCamera>& cams,
                             int k, const Eigen::Vector3d& keep) {
  const PinholeCamera color = PinholeCamera::fromCameraInfo(colorInfo(), "test");
  Eigen::Vector2d uv;
  ASSERT_TRUE(color.project(cams[k].T_world_color.inverse() * keep, &uv));
  auto& boxes = (*inputs)[k].frame.boxes;
  boxes.erase(std::remove_if(boxes.begin(), boxes.end(),
                             [&](const DetectionBox& x) {
                               return x.label == EndLabel::kBoxEnd &&
                                      !(uv.x() >= x.x_min - 5 && uv.x() <= x.x_max + 5 &&
                                        uv.y() >= x.y_min - 5 && uv.y() <= x.y_max + 5);
                             }),
               boxes.end());
}

// Points of `pts` on the vertical joint at `a` (within 0.12 m of its axis).
size_t pointsOnJoint(const std::vector<CloudPoint>& pts, const Eigen::Vector3d& a) {
  size_t n = 0;
  for (const auto& p : pts) n += std::hypot(p.p_world.x() - a.x(), p.p_world.y() - a.y()) < 0.12;
  return n;
}

TEST(Carving, ACameraBlockedByAnObstacleDoesNotVetoWhatItCannotSee) {
  // Box end A behind two posts as cam1 and cam2 see it; their detector has no box on A, only on
  // another box end B (and on a pin end C beyond A: the depth between B and C is in their crop,
  // CycleCamera::crop). Without the occlusion test they vote A's points out (4 of 6 < 0.75).
  Scene scene;
  const Eigen::Vector3d a(5, 5, 1.2), b(6.0, 3.8, 1.2), c(4.0, 6.2, 1.2);
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt(a, {0, 0, 1})));
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt(b, {0, 0, 1})));
  scene.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt(c, {0, 0, 1})));
  auto cams = ring({5, 5, 1.0}, 5.5, 4.5);
  for (int k : {0, 1}) {
    const Eigen::Vector3d view = cams[k].T_world_color.translation() - a;
    const Eigen::Vector2d dir = Eigen::Vector2d(view.x(), view.y()).normalized();
    scene.posts.push_back({Eigen::Vector2d(a.x(), a.y()) + 0.8 * dir, 0.3, 0.0, 3.5});
  }
  auto inputs = renderAll(scene, cams, {});
  for (int k : {0, 1}) {
    keepOnlyBoxEndBoxAround(&inputs, cams, k, b);
    ASSERT_EQ(inputs[k].frame.boxes.size(), 2u) << cams[k].name;
  }
  EstimatorConfig cfg = testConfig();
  // B is 1.6 m from A: with box_reach, cam1 and cam2 would not vote on A whatever they see; with
  // count_boxes, the four cameras that boxed A as well would keep it (checked last).
  cfg.carving.box_reach = 0.0;
  cfg.carving.count_boxes = false;
  std::vector<CycleCamera> cc;
  std::array<std::vector<CloudPoint>, kNumEnds> raw;
  cutOutAll(inputs, cfg, &cc, &raw);
  const size_t before = pointsOnJoint(raw[0], a);
  ASSERT_GT(before, 200u);
  cfg.carving.occlusion_margin = 0.0;
  EXPECT_LT(pointsOnJoint(carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving), a), before / 4);
  cfg.carving.occlusion_margin = EstimatorConfig().carving.occlusion_margin;
  EXPECT_GT(pointsOnJoint(carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving), a),
            before * 9 / 10);
  cfg.carving.occlusion_margin = 0.0;
  cfg.carving.count_boxes = true;
  EXPECT_GT(pointsOnJoint(carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving), a),
            before * 9 / 10);
}

/// Two upright box ends A and B seen by a ring of six cameras around `centre`; cam1 and cam2
/// keep only their box around `seen` (their detectors missed the other end). The cut-out points
/// and the cycle's cameras.
void twoBoxEndsOneMissedTwice(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                              const Eigen::Vector3d& centre, const Eigen::Vector3d& seen,
                              const EstimatorConfig& cfg, std::vector<CycleCamera>* cc,
                              std::array<std::vector<CloudPoint>, kNumEnds>* raw) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt(a, {0, 0, 1})));
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt(b, {0, 0, 1})));
  auto cams = ring(centre, 5.5, 4.5);
  auto inputs = renderAll(scene, cams, {});
  for (size_t k = 2; k < inputs.size(); ++k)
    ASSERT_EQ(inputs[k].frame.boxes.size(), 2u) << cams[k].name << ": both ends boxed";
  for (int k : {0, 1}) {
    keepOnlyBoxEndBoxAround(&inputs, cams, k, seen);
    ASSERT_EQ(inputs[k].frame.boxes.size(), 1u) << cams[k].name;
  }
  cutOutAll(inputs, cfg, cc, raw);
}

TEST(Carving, ACameraWhoseOnlyBoxIsOnAFarJointDoesNotVetoTheJointItMissed) {
  // Box end A in full view of all six cameras; the detectors of cam1 and cam2 miss it and see
  // only another box end B, 1.6 m away. Their boxes on B say nothing about A.
  const Eigen::Vector3d a(5, 5, 1.2), b(6.0, 3.8, 1.2);
  EstimatorConfig cfg = testConfig();
  std::vector<CycleCamera> cc;
  std::array<std::vector<CloudPoint>, kNumEnds> raw;
  twoBoxEndsOneMissedTwice(a, b, {5, 5, 1.0}, b, cfg, &cc, &raw);
  ASSERT_FALSE(HasFatalFailure());
  const size_t before = pointsOnJoint(raw[0], a);
  ASSERT_GT(before, 200u);
  // Every box votes: cam1 and cam2 veto A's points (4 of 6 < 0.75) (count_boxes, which lets the
  // four cameras that boxed A as well keep it, is tested in the next test).
  cfg.carving.box_reach = 0.0;
  cfg.carving.count_boxes = false;
  EXPECT_LT(pointsOnJoint(carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving), a), before / 4);
  // Only boxes within 0.5 m vote: A is kept; B too (the cameras that see it agree).
  cfg.carving.box_reach = 0.5;
  const auto kept = carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving);
  EXPECT_GT(pointsOnJoint(kept, a), before * 9 / 10);
  EXPECT_GT(pointsOnJoint(kept, b), pointsOnJoint(raw[0], b) * 9 / 10);
}

TEST(Carving, CamerasThatMissedTheSecondOfTwoEndsSideBySideDoNotCarveItAway) {
  // Two box ends A and B side by side, 0.4 m apart (two pipes on a catwalk); the detectors of
  // cam1 and cam2 box A only. Within box_reach of A, they would veto B (4 of 6 < 0.75); with
  // carving/count_boxes the four cameras that boxed both ends decide B.
  const Eigen::Vector3d a(5, 5, 1.2), b(5, 5.4, 1.2);
  EstimatorConfig cfg = testConfig();
  std::vector<CycleCamera> cc;
  std::array<std::vector<CloudPoint>, kNumEnds> raw;
  twoBoxEndsOneMissedTwice(a, b, {5, 5.2, 1.0}, a, cfg, &cc, &raw);
  ASSERT_FALSE(HasFatalFailure());
  const size_t before_a = pointsOnJoint(raw[0], a), before_b = pointsOnJoint(raw[0], b);
  ASSERT_GT(before_b, 200u);
  cfg.carving.count_boxes = false;
  EXPECT_LT(pointsOnJoint(carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving), b), before_b / 4);
  cfg.carving.count_boxes = true;
  const auto kept = carve(raw[0], EndLabel::kBoxEnd, cc, cfg.carving);
  EXPECT_GT(pointsOnJoint(kept, b), before_b * 9 / 10);
  EXPECT_GT(pointsOnJoint(kept, a), before_a * 9 / 10);
}

TEST(Instances, ClustersAreConnectedGroupsLargestFirst) {
  // Two blobs 0.5 m apart, a chain of points 3 cm apart (one cluster), a few stray points.
  std::vector<CloudPoint> pts;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-0.05f, 0.05f);
  auto add = [&](const Eigen::Vector3f& p) {
    CloudPoint c;
    c.p_world = p;
    pts.push_back(c);
  };
  for (int i = 0; i < 100; ++i) add(Eigen::Vector3f(1 + u(rng), 1 + u(rng), 1 + u(rng)));
  for (int i = 0; i < 60; ++i) add(Eigen::Vector3f(1.5f + u(rng), 1 + u(rng), 1 + u(rng)));
  for (int i = 0; i < 80; ++i) add(Eigen::Vector3f(3 + 0.03f * i, 2, 1));
  for (int i = 0; i < 5; ++i) add(Eigen::Vector3f(-2.0f - i, 0, 0));
  const auto clusters = euclideanClusters(pts, 0.08, 20);
  ASSERT_EQ(clusters.size(), 3u);
  EXPECT_EQ(clusters[0].size(), 100u);
  EXPECT_EQ(clusters[1].size(), 80u);
  EXPECT_EQ(clusters[2].size(), 60u);
  EXPECT_EQ(clusters[0].front(), 0u);
  EXPECT_EQ(clusters[1].front(), 160u);
  EXPECT_TRUE(std::is_sorted(clusters[1].begin(), clusters[1].end()));
  EXPECT_EQ(euclideanClusters(pts, 0.08, 20), clusters);  // deterministic
  EXPECT_EQ(euclideanClusters(pts, 1.0, 20).size(), 2u);  // the blobs join
}

/// Points of a lying joint (radius 84 mm, axis along x at height z_axis) on its upper and side
/// surface, 0.6 m long, around y0; with ~1 cm of depth-like noise (seeded).
void addLyingJoint(std::vector<CloudPoint>* pts, float y0, float z_axis, std::mt19937* rng) {
  std::uniform_real_distribution<float> x(0.0f, 0.6f), a(0.2f, 2.94f);
  std::normal_distribution<float> n(0.0f, 0.01f);
  for (int i = 0; i < 1500; ++i) {
    const float t = a(*rng);
    CloudPoint c;
    c.p_world = Eigen::Vector3f(x(*rng), y0 + 0.084f * std::cos(t) + n(*rng),
                                z_axis + 0.084f * std::sin(t) + n(*rng));
    pts->push_back(c);
  }
}

/// `n` points of a catwalk top at z = 1.0 (x from -0.1 to 0.7, y from y0 to y1), with ~1 cm of
/// depth-like noise (seeded).
void addCatwalkTop(std::vector<CloudPoint>* pts, float y0, float y1, int n, std::mt19937* rng) {
  std::uniform_real_distribution<float> ux(-0.1f, 0.7f), uy(y0, y1);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  for (int i = 0; i < n; ++i) {
    CloudPoint c;
    c.p_world = Eigen::Vector3f(ux(*rng), uy(*rng), 1.0f + noise(*rng));
    pts->push_back(c);
  }
}

TEST(Instances, SplitAtSupportSeparatesTwoPipesOnOneCatwalk) {
  // Two lying joints 0.4 m apart (axis to axis) on a catwalk top at z = 1.0 that spans both,
  // with depth noise and a few loose points between them: one cluster, split into two.
  std::mt19937 rng(120);
  std::vector<CloudPoint> pts;
  addLyingJoint(&pts, 0.0f, 1.084f, &rng);
  addLyingJoint(&pts, 0.4f, 1.084f, &rng);
  const size_t joints = pts.size();
  addCatwalkTop(&pts, -0.3f, 0.7f, 2500, &rng);
  for (int i = 0; i < 10; ++i) {  // loose points bridging the gap (flying pixels)
    CloudPoint c;
    c.p_world = Eigen::Vector3f(0.3f, 0.1f + 0.02f * i, 1.1f);
    pts.push_back(c);
  }
  EstimatorConfig::AxisFit ac;
  const auto joined = euclideanClusters(pts, 0.08, 50);
  ASSERT_EQ(joined.size(), 1u) << "seed 120: the catwalk should join the joints";
  const auto parts = splitAtSupport(pts, joined, 0.08, 50, 0.168, ac);
  ASSERT_EQ(parts.size(), 2u) << "seed 120";
  for (const auto& part : parts) {
    size_t left = 0, right = 0;  // joint points of the pipe at y = 0 and at y = 0.4
    for (size_t i : part)
      if (i < joints) (i < joints / 2 ? left : right) += 1;
    EXPECT_TRUE(left == 0 || right == 0) << "a part holds both joints (seed 120)";
    EXPECT_GT(left + right, joints / 2 * 9 / 10) << "a joint lost its points (seed 120)";
    EXPECT_TRUE(std::is_sorted(part.begin(), part.end()));
  }
  EXPECT_EQ(splitAtSupport(pts, joined, 0.08, 50, 0.168, ac), parts);  // deterministic
  // Parts nearer than min_separation are one joint: the cluster stays whole.
  EXPECT_EQ(splitAtSupport(pts, joined, 0.08, 50, 0.5, ac), joined);
}

TEST(Instances, SplitAtSupportKeepsOneJointOnTheFloorWhole) {
  std::mt19937 rng(121);
  std::vector<CloudPoint> pts;
  addLyingJoint(&pts, 0.0f, 1.084f, &rng);
  addCatwalkTop(&pts, -0.3f, 0.3f, 1500, &rng);
  EstimatorConfig::AxisFit ac;
  const auto clusters = euclideanClusters(pts, 0.08, 50);
  ASSERT_EQ(clusters.size(), 1u);
  EXPECT_EQ(splitAtSupport(pts, clusters, 0.08, 50, 0.168, ac), clusters) << "seed 121";
}

TEST(Instances, ChoiceByMeanCostWithIncumbentAmbiguityAndAbsentBetterOne) {
  const EstimatorConfig::Instances ic;  // margin 0.04, 3 decisions, 30 averaged, 3 s memory
  const Eigen::Vector3d a(1, 1, 1), b(2, 1, 1);
  const int64_t dt = 33000000;
  size_t near_a = 100;  // cut-out points at A's place
  auto near = [&](const Eigen::Vector3d& o, double) { return (o - a).norm() < 0.1 ? near_a : 0; };
  auto fits = [&](double cost_a, double cost_b, bool a_fits = true) {
    return std::vector<InstanceFit>{{a_fits, a, cost_a, {}}, {true, b, cost_b, {}}};
  };
  std::vector<InstanceMemory> memory;
  int64_t t = 0;
  // A fits 20 % better: no choice before min_decisions, then A.
  for (int k = 0; k < 5; ++k, t += dt) {
    SCOPED_TRACE("cycle " + std::to_string(k));
    const InstanceChoice c =
        chooseInstance(&memory, fits(1.0e-4, 1.2e-4), -1, t, near, 40, ic, "box_end");
    if (k < ic.min_decisions - 1) {
      EXPECT_EQ(c.index, -1);
      EXPECT_NE(c.reason.find("not choosing yet"), std::string::npos) << c.reason;
    } else {
      EXPECT_EQ(c.index, 0) << c.reason;
    }
  }
  ASSERT_EQ(memory.size(), 2u);
  // A has no fit this cycle but is still there: B is not taken in its place.
  InstanceChoice c =
      chooseInstance(&memory, fits(0, 1.2e-4, false), -1, t, near, 40, ic, "box_end");
  EXPECT_EQ(c.index, -1);
  EXPECT_NE(c.reason.find("no fit this cycle"), std::string::npos) << c.reason;
  t += dt;
  // B now fits better: A, the incumbent, keeps its place until B's mean is lower by the margin.
  int switched = -1;
  for (int k = 0; k < 40 && switched < 0; ++k, t += dt) {
    c = chooseInstance(&memory, fits(1.2e-4, 1.0e-4), -1, t, near, 40, ic, "box_end");
    ASSERT_GE(c.index, 0) << c.reason;
    if (c.index == 1) switched = k;
  }
  EXPECT_GT(switched, 0);
  EXPECT_LT(switched, 30);
  // A moved away (no points at its place) and fails: B is taken.
  near_a = 0;
  c = chooseInstance(&memory, fits(0, 1.0e-4, false), -1, t, near, 40, ic, "box_end");
  EXPECT_EQ(c.index, 1) << c.reason;
  // Two alike, after a gap longer than memory_s (memory forgotten): no pose, both named.
  t += static_cast<int64_t>((ic.memory_s + 1) * 1e9);
  for (int k = 0; k < 4; ++k, t += dt)
    c = chooseInstance(&memory, fits(1.0e-4, 1.01e-4), -1, t, near, 40, ic, "pin_end");
  EXPECT_EQ(memory.size(), 2u);
  EXPECT_EQ(c.index, -1);
  EXPECT_NE(c.reason.find("pin_end instances fit alike"), std::string::npos) << c.reason;
  EXPECT_NE(c.reason.find("(1, 1, 1)"), std::string::npos) << c.reason;
  EXPECT_NE(c.reason.find("(2, 1, 1)"), std::string::npos) << c.reason;
  // A track keeps its instance while the two stay alike.
  c = chooseInstance(&memory, fits(1.0e-4, 1.01e-4), 1, t, near, 40, ic, "pin_end");
  EXPECT_EQ(c.index, 1) << c.reason;
}

TEST(Instances, AnotherPipeSizeDoesNotCompeteAndANewcomerWaitsForTheOthers) {
  const EstimatorConfig::Instances ic;  // 3 decisions, radius_difference 2.5 mm
  const Eigen::Vector3d a(1, 1, 1), b(2, 1, 1);
  const int64_t dt = 33000000;
  bool b_there = true;  // cut-out points at B's place
  auto near = [&](const Eigen::Vector3d& o, double) {
    return (o - b).norm() < 0.1 && !b_there ? size_t{0} : size_t{100};
  };
  auto radius = [](double offset) {
    RadiusCheck r;
    r.ok = true;
    r.offset = offset;
    r.std = 0.001;
    r.points = 200;
    return r;
  };
  // A fits 10 % better by cost but measures 4 mm thinner than B, which measures the model's
  // radius: from min_decisions on, B is taken.
  std::vector<InstanceMemory> memory;
  int64_t t = 0;
  for (int k = 0; k < 5; ++k, t += dt) {
    SCOPED_TRACE("cycle " + std::to_string(k));
    const std::vector<InstanceFit> fits{{true, a, 1.0e-4, radius(-0.0035)},
                                        {true, b, 1.1e-4, radius(0.0005)}};
    const InstanceChoice c = chooseInstance(&memory, fits, -1, t, near, 40, ic, "box_end");
    if (k < ic.min_decisions - 1)
      EXPECT_EQ(c.index, -1) << c.reason;
    else
      EXPECT_EQ(c.index, 1) << c.reason;
  }
  // B gone (still remembered), A alone: no pose, and the reason names both places.
  b_there = false;
  InstanceChoice c = chooseInstance(&memory, {{true, a, 1.0e-4, radius(-0.0035)}}, -1, t, near,
                                    40, ic, "box_end");
  EXPECT_EQ(c.index, -1);
  EXPECT_NE(c.reason.find("another pipe size"), std::string::npos) << c.reason;
  EXPECT_NE(c.reason.find("(2, 1, 1)"), std::string::npos) << c.reason;
  // Relative: both measured 3 mm thicker (a rig's common depth offset) change nothing, and a
  // lone joint is never judged by its radius (nothing to compare it with).
  std::vector<InstanceMemory> biased, lone;
  for (int k = 0; k < 4; ++k, t += dt) {
    SCOPED_TRACE("biased / lone cycle " + std::to_string(k));
    c = chooseInstance(&biased,
                       {{true, a, 1.0e-4, radius(0.0030)}, {true, b, 1.2e-4, radius(0.0035)}},
                       -1, t, near, 40, ic, "box_end");
    EXPECT_EQ(c.index, k < ic.min_decisions - 1 ? -1 : 0) << c.reason;
    c = chooseInstance(&lone, {{true, a, 1.0e-4, radius(-0.005)}}, -1, t, near, 40, ic,
                       "box_end");
    EXPECT_EQ(c.index, 0) << c.reason;
  }
  // With the check off, A is the better one.
  EstimatorConfig::Instances off = ic;
  off.radius_difference = 0.0;
  std::vector<InstanceMemory> memory_off;
  for (int k = 0; k < 3; ++k, t += dt)
    c = chooseInstance(&memory_off,
                       {{true, a, 1.0e-4, radius(-0.0035)}, {true, b, 1.1e-4, radius(0.0005)}},
                       -1, t, near, 40, off, "box_end");
  EXPECT_EQ(c.index, 0) << c.reason;
  // A newcomer that is the only competing fit, beside a fit of this cycle that does not compete
  // (it failed, or took the other model), waits for min_decisions; alone, it is taken at once.
  // A fit that fails every cycle (a detection on clutter) holds it only that long.
  std::vector<InstanceMemory> fresh;
  for (int k = 0; k < 4; ++k, t += dt) {
    SCOPED_TRACE("newcomer cycle " + std::to_string(k));
    c = chooseInstance(&fresh, {{false, a, 0.0, {}}, {true, b, 1.0e-4, {}}}, -1, t, near, 40,
                       ic, "pin_end");
    if (k < ic.min_decisions - 1) {
      EXPECT_EQ(c.index, -1);
      EXPECT_NE(c.reason.find("not choosing yet"), std::string::npos) << c.reason;
    } else {
      EXPECT_EQ(c.index, 1) << c.reason;
    }
  }
  std::vector<InstanceMemory> alone;
  c = chooseInstance(&alone, {{true, b, 1.0e-4, {}}}, -1, t, near, 40, ic, "pin_end");
  EXPECT_EQ(c.index, 0) << c.reason;
}

// The radii of a joint's first decisions scatter by 1-2 mm: two sizes are told apart only when
// the means differ by more than instances.radius_difference plus their standard errors.
// The offsets are those of cluttered seed 1's first decisions (its 5" pin end and the lying
// 4.5" pipe beside it), whose scatter once ruled the 5" end out as "another pipe size".
TEST(Instances, AFitReversedAgainstADecidedInstanceIsThatInstanceFlipped) {
  // A lying pin end decided 5 times at (2.2, 6.25, 1.09), pointing along -x; a fit of the same
  // end with its pin taken for the tube points along +x a tong length (0.26 m) toward the tube
  // (catwalk_twin seed 191).
  EstimatorConfig::Instances ic;
  const int64_t now = 5000000000;
  InstanceMemory pin;
  pin.origin = Eigen::Vector3d(2.2, 6.25, 1.09);
  pin.z = -Eigen::Vector3d::UnitX();
  pin.decisions = 5;
  pin.stamp_ns = now - 200000000;
  std::vector<InstanceMemory> memory{pin};
  const Eigen::Vector3d flipped_at(2.46, 6.25, 1.09), x = Eigen::Vector3d::UnitX();
  EXPECT_EQ(reversedAgainst(flipped_at, x, memory, now, ic), &memory[0]);
  // Its own direction, another pipe beside it (0.4 m across), too far along the axis: not it.
  EXPECT_EQ(reversedAgainst(flipped_at, -x, memory, now, ic), nullptr);
  EXPECT_EQ(reversedAgainst({2.46, 6.65, 1.09}, x, memory, now, ic), nullptr);
  EXPECT_EQ(reversedAgainst({2.7, 6.25, 1.09}, x, memory, now, ic), nullptr);
  // An instance of its own direction within track_gate: another end that is decided so.
  std::vector<InstanceMemory> with_own = memory;
  InstanceMemory own = pin;
  own.origin = Eigen::Vector3d(2.42, 6.25, 1.09);
  own.z = x;
  with_own.push_back(own);
  EXPECT_EQ(reversedAgainst(flipped_at, x, with_own, now, ic), nullptr);
  // Not decided min_decisions times, forgotten (older than memory_s), or the rule off.
  memory[0].decisions = ic.min_decisions - 1;
  EXPECT_EQ(reversedAgainst(flipped_at, x, memory, now, ic), nullptr);
  memory[0].decisions = 5;
  EXPECT_EQ(reversedAgainst(flipped_at, x, memory,
                            pin.stamp_ns + static_cast<int64_t>((ic.memory_s + 0.1) * 1e9), ic),
            nullptr);
  EstimatorConfig::Instances off = ic;
  off.reversal_reach = 0.0;
  EXPECT_EQ(reversedAgainst(flipped_at, x, memory, now, off), nullptr);
}

// A pipe's two ends, and a stand's pin end stabbed into a stump's box end, lie on one axis line
// facing each other; the neighbour pipe's end 0.4 m across (catwalk_twin) does not.
TEST(Instances, CoaxialEndsFaceEachOtherOnOneAxisLine) {
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), z = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d box(2.2, 5.85, 1.09), pin(7.2, 5.85, 1.09);  // pipe_a, 5 m long
  // The pipe's own ends, with 1 deg of axis error each (8.7 cm over 5 m each way).
  const Eigen::Vector3d tilted = Eigen::AngleAxisd(M_PI / 180, z) * x;
  EXPECT_TRUE(coaxialEnds(box, -x, pin, x, 0.15, 10.0));
  EXPECT_TRUE(coaxialEnds(box, -tilted, pin, tilted, 0.15, 10.0));
  EXPECT_TRUE(coaxialEnds(pin, x, box, -x, 0.15, 10.0));  // symmetric
  // The stump's box end (z up) and the stand's pin end 0.36 m above it, 3 cm off the axis.
  EXPECT_TRUE(coaxialEnds({4.694, 6.05, 0.8}, z, {4.724, 6.05, 1.164}, -z, 0.15, 10.0));
  // The neighbour pipe's pin end, 0.4 m across; the same direction (two box ends in a row);
  // at right angles; 20 deg apart (beyond max_angle_deg).
  EXPECT_FALSE(coaxialEnds(box, -x, {7.2, 6.25, 1.09}, x, 0.15, 10.0));
  EXPECT_FALSE(coaxialEnds(box, -x, pin, -x, 0.15, 10.0));
  EXPECT_FALSE(coaxialEnds(box, -x, pin, z, 0.15, 10.0));
  const Eigen::Vector3d twenty = Eigen::AngleAxisd(20 * M_PI / 180, z) * x;
  EXPECT_FALSE(coaxialEnds(box, -x, box + 5 * twenty, twenty, 0.15, 10.0));
  // Degenerate input: no axis, a negative or NaN reach.
  EXPECT_FALSE(coaxialEnds(box, Eigen::Vector3d::Zero(), pin, x, 0.15, 10.0));
  EXPECT_FALSE(coaxialEnds(box, -x, pin, x, -1.0, 10.0));
  EXPECT_FALSE(coaxialEnds(box, -x, pin, x, std::nan(""), 10.0));
}

TEST(Instances, EndsOnOneJointFaceTheSameWayOnOneAxisLine) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ(), x = Eigen::Vector3d::UnitX();
  // thesis_vertical, seed 200, 3-1/2" NC38 4-3/4" OD: the box end and the pin model fitted to
  // its joint 0.124 m lower, 1.8 cm off its axis and 8.4 deg tilted.
  const Eigen::Vector3d box(4.6936, 5.2975, 0.2225), on_box(4.7029, 5.2821, 0.0983);
  const Eigen::Vector3d tilted = Eigen::AngleAxisd(8.4 * M_PI / 180, x) * z;
  EXPECT_TRUE(endsOnOneJoint(box, z, on_box, tilted, 0.05, 0.5, 10.0));
  EXPECT_TRUE(endsOnOneJoint(on_box, tilted, box, z, 0.05, 0.5, 10.0));  // symmetric
  // The true pin end, 1.5 m away; a pin end stabbed into the box (facing it, at its face);
  // the same joint more than `along` apart; off the axis line; 20 deg apart.
  EXPECT_FALSE(endsOnOneJoint(box, z, {4.69, 6.79, 0.28}, z, 0.05, 0.5, 10.0));
  EXPECT_FALSE(endsOnOneJoint(box, z, box + 0.01 * z, -z, 0.05, 0.5, 10.0));
  EXPECT_FALSE(endsOnOneJoint(box, z, box - 0.6 * z, z, 0.05, 0.5, 10.0));
  EXPECT_FALSE(endsOnOneJoint(box, z, box + 0.08 * x, z, 0.05, 0.5, 10.0));
  const Eigen::Vector3d twenty = Eigen::AngleAxisd(20 * M_PI / 180, x) * z;
  EXPECT_FALSE(endsOnOneJoint(box, z, box - 0.1 * z, twenty, 0.05, 0.5, 10.0));
  // Degenerate input: no axis, a negative or NaN reach or length.
  EXPECT_FALSE(endsOnOneJoint(box, Eigen::Vector3d::Zero(), on_box, z, 0.05, 0.5, 10.0));
  EXPECT_FALSE(endsOnOneJoint(box, z, on_box, z, -1.0, 0.5, 10.0));
  EXPECT_FALSE(endsOnOneJoint(box, z, on_box, z, 0.05, std::nan(""), 10.0));
}

TEST(Instances, ScatteredRadiiRuleNoSizeOutUntilTheDifferenceIsClear) {
  const EstimatorConfig::Instances ic;  // 3 decisions, radius_difference 2.5 mm
  const Eigen::Vector3d a(1, 1, 1), b(2, 1, 1);
  const int64_t dt = 33000000;
  auto near = [](const Eigen::Vector3d&, double) { return size_t{100}; };
  auto radius = [](double offset) {
    RadiusCheck r;
    r.ok = true;
    r.offset = offset;
    r.std = 0.001;
    r.points = 200;
    return r;
  };
  // A (the model's size) fits better; B measures thinner, nearer the model's radius by chance.
  const double a_mm[] = {3.1, 1.5, 2.0}, b_mm[] = {-0.2, -2.8, -1.5};
  std::vector<InstanceMemory> memory;
  int64_t t = 0;
  InstanceChoice c;
  for (int k = 0; k < 3; ++k, t += dt)
    c = chooseInstance(&memory,
                       {{true, a, 1.0e-4, radius(a_mm[k] * 1e-3)},
                        {true, b, 1.2e-4, radius(b_mm[k] * 1e-3)}},
                       -1, t, near, 40, ic, "pin_end");
  // Means 2.2 and -1.5 mm: 3.7 mm apart, within 2.5 mm plus two standard errors (1.8 mm).
  EXPECT_EQ(c.index, 0) << c.reason;
  // A clear difference is still found: B fits better, but over 20 decisions A reads 0.5 mm and
  // B 4.5 mm thin, each scattering by 1 mm.
  std::vector<InstanceMemory> clear;
  for (int k = 0; k < 20; ++k, t += dt) {
    const double wobble = (k % 2 ? 1.0 : -1.0) * 1e-3;
    c = chooseInstance(&clear,
                       {{true, a, 1.2e-4, radius(0.5e-3 + wobble)},
                        {true, b, 1.0e-4, radius(-4.5e-3 - wobble)}},
                       -1, t, near, 40, ic, "pin_end");
  }
  EXPECT_EQ(c.index, 0) << c.reason;
}

TEST(AxisFit, KnownAxisUnderNoiseAndOutliers) {
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> uni(-1, 1);
    std::normal_distribution<double> gauss(0, 0.006);
    const Eigen::Vector3d axis = Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized();
    const Eigen::Vector3d origin(5 + uni(rng), 5 + uni(rng), 1 + uni(rng));
    const Eigen::Isometry3d T = canonicalPose(origin, axis);
    const double R = 0.08415;
    std::vector<Eigen::Vector3f> pts;
    for (int i = 0; i < 2000; ++i) {
      const double phi = M_PI * (uni(rng) + 1) * 0.6;  // ~ 216 deg of the surface seen
      const double z = -0.3 * (uni(rng) + 1) / 2;
      const double r = R + gauss(rng);
      pts.push_back((T * Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z)).cast<float>());
    }
    for (int i = 0; i < 500; ++i)  // 20 % outliers within 0.5 m
      pts.push_back((origin + 0.5 * Eigen::Vector3d(uni(rng), uni(rng), uni(rng))).cast<float>());
    EstimatorConfig::AxisFit cfg;
    cfg.seed = seed;
    cfg.max_points = 2500;  // the pipeline uses fewer: its axis is only the initial guess
    const AxisFitResult r = fitCylinderAxis(pts, R, cfg);
    ASSERT_TRUE(r.ok);
    const double angle = std::acos(std::min(1.0, std::abs(r.axis.direction.dot(axis))));
    EXPECT_LT(angle, 0.5 * kDeg);
    const Eigen::Vector3d q = origin - r.axis.point;
    EXPECT_LT((q - q.dot(axis) * axis).norm(), 0.004);
  }
}

TEST(ProfileRegistration, RayHitsTheVisibleSurfaceAndUndoesEdgeBias) {
  const ToolJointDimensions dims;
  const ProfileModel box(EndLabel::kBoxEnd, dims);
  const double R = dims.tool_joint_od / 2;
  double s;
  Eigen::Vector2d zr, n;
  // Straight down onto the end-face annulus (z = 0, the box's opening faces +z): the hit is 1 m
  // below a point 1 m above the face, the normal faces the camera (+z).
  const double r_face = 0.5 * (R + dims.box_counterbore_diameter / 2);
  ASSERT_TRUE(box.rayHit(Eigen::Vector3d(r_face, 0, 1.0), Eigen::Vector3d(0, 0, -1), -5.0, &s,
                         &zr, &n));
  EXPECT_NEAR(s, 1.0, 1e-9);
  EXPECT_NEAR(zr.x(), 0.0, 1e-9);
  EXPECT_NEAR(zr.y(), r_face, 1e-9);
  EXPECT_NEAR(n.x(), 1.0, 1e-9);
  // Horizontally onto the outer wall 0.1 m below the face: the hit is on the cylinder r = R.
  ASSERT_TRUE(box.rayHit(Eigen::Vector3d(-1.0, 0, -0.1), Eigen::Vector3d(1, 0, 0), -5.0, &s, &zr,
                         &n));
  EXPECT_NEAR(zr.y(), R, 1e-9);
  EXPECT_NEAR(s, 1.0 - R, 1e-9);
  EXPECT_NEAR(n.y(), 1.0, 1e-9);
  // A ray passing beside the joint misses it.
  EXPECT_FALSE(box.rayHit(Eigen::Vector3d(-1.0, R + 0.05, -0.1), Eigen::Vector3d(1, 0, 0), -5.0,
                          &s, &zr, &n));
  // A point pushed 1 cm into the joint near the rim along a 45 degree ray: closest-point
  // matching takes the outer wall (about 3 mm away), the ray its true surface, the end face,
  // at the 1 cm it was pushed along the ray.
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 0, -1).normalized();
  const Eigen::Vector3d on_face(R - 0.004, 0, 0);
  const Eigen::Vector3d p = on_face + 0.01 * dir;
  const Eigen::Vector3f eye = (on_face - 3.0 * dir).cast<float>();
  const double e_closest = profileResidual(box, p, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(),
                                           Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), nullptr);
  bool hit = false;
  const double e_ray =
      profileResidual(box, p, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(),
                      Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), &eye, nullptr, &hit);
  EXPECT_TRUE(hit);
  EXPECT_LT(std::abs(e_closest), 0.005);
  EXPECT_NEAR(e_ray, -0.01 * std::cos(M_PI / 4), 1e-6);  // behind the face, point-to-plane
}

TEST(ProfileRegistration, SilhouettePointsSteerOnlyBesideTheSidesOfAWellExplainedFit) {
  // A vertical box end seen from one camera 4 m away (x toward the joint): exact points where
  // the camera's rays meet it, and points 4 mm beside its +y side whose rays miss it (what
  // lateral noise makes of the pixels just outside its silhouette).
  const ToolJointDimensions dims;
  const ProfileModel box(EndLabel::kBoxEnd, dims);
  const double R = dims.tool_joint_od / 2;
  const Eigen::Vector3d eye(-4.0, 0.0, -0.1);
  std::vector<Eigen::Vector3f> pts, eyes;
  for (double b = -0.2; b <= -0.02; b += 0.004)
    for (double a = -0.1; a <= 0.1; a += 0.004) {
      const Eigen::Vector3d d = (Eigen::Vector3d(0, a, b) - eye).normalized();
      double t;
      Eigen::Vector2d zr, n;
      if (!box.rayHit(eye, d, 0.0, &t, &zr, &n)) continue;
      pts.push_back((eye + t * d).cast<float>());
    }
  const size_t hits = pts.size();
  ASSERT_GT(hits, 300u);
  for (double z = -0.19; z <= -0.03; z += 0.002) pts.emplace_back(0.0f, R + 0.004, z);
  for (size_t i = hits; i < pts.size(); ++i) {
    double t;
    Eigen::Vector2d zr, n;
    ASSERT_FALSE(box.rayHit(eye, (pts[i].cast<double>() - eye).normalized(), 0.0, &t, &zr, &n));
  }
  eyes.assign(pts.size(), eye.cast<float>());
  EstimatorConfig::ProfileFit cfg;
  auto fit = [&](const std::vector<Eigen::Vector3f>& p, bool silhouettes) {
    cfg.silhouette_points = silhouettes;
    std::vector<Eigen::Vector3f> e(p.size(), eye.cast<float>());
    const ProfileFitResult f = refineProfile(p, std::vector<float>(p.size(), 0.003f),
                                             Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(),
                                             box, cfg, 10, true, &e);
    EXPECT_TRUE(f.ok);
    return f;
  };
  const ProfileFitResult off = fit(pts, false), on = fit(pts, true);
  EXPECT_LT(std::abs(off.origin.y()), 1e-4) << "points whose rays miss do not steer when off";
  EXPECT_GT(on.origin.y(), 2e-4) << "they pull the joint toward them when on";
  // They add nothing to the reported certainty: the fit does not look surer with them.
  for (int k = 0; k < 5; ++k) EXPECT_GE(on.covariance(k, k), 0.95 * off.covariance(k, k)) << k;
  // A fit that explains less than silhouette_min_inlier_fraction of its points (here a cloud
  // of stray points 5 cm off the joint) is not steered by them.
  std::vector<Eigen::Vector3f> stray = pts;
  for (size_t i = 0; i < hits; ++i) stray.push_back(pts[i] + Eigen::Vector3f(-0.05f, 0, 0));
  EXPECT_LT(std::abs(fit(stray, true).origin.y()), 1e-4);
  cfg.silhouette_min_inlier_fraction = 0.4;  // the stray points then no longer stop them
  EXPECT_GT(fit(stray, true).origin.y(), 2e-4);
}

TEST(ProfileRegistration, IncidenceNoiseWeighsGrazingPointsLess) {
  // A vertical box end seen from one camera 4 m away (x toward the joint). The points of its +y
  // side seen at more than 60 deg incidence lie 20 mm too far along their rays (the depth noise
  // grows toward grazing incidence), the others exactly on it.
  const ToolJointDimensions dims;
  const ProfileModel box(EndLabel::kBoxEnd, dims);
  const Eigen::Vector3d eye(-4.0, 0.0, -0.1);
  std::vector<Eigen::Vector3f> pts;
  size_t grazing = 0;
  for (double b = -0.2; b <= -0.02; b += 0.004)
    for (double a = -0.1; a <= 0.1; a += 0.002) {
      const Eigen::Vector3d d = (Eigen::Vector3d(0, a, b) - eye).normalized();
      double t;
      Eigen::Vector2d zr, n;
      if (!box.rayHit(eye, d, 0.0, &t, &zr, &n)) continue;
      const Eigen::Vector3d hit = eye + t * d;
      const Eigen::Vector3d normal(hit.x(), hit.y(), 0.0);  // the side's, radial
      const bool off_side = a > 0 && std::abs(normal.normalized().dot(d)) < 0.5;
      grazing += off_side ? 1 : 0;
      pts.push_back((hit + (off_side ? 0.02 : 0.0) * d).cast<float>());
    }
  ASSERT_GT(grazing, 20u);
  const std::vector<Eigen::Vector3f> eyes(pts.size(), eye.cast<float>());
  EstimatorConfig::ProfileFit cfg;
  cfg.silhouette_points = false;
  auto shift = [&](double incidence_noise) {
    cfg.incidence_noise = incidence_noise;
    const ProfileFitResult f =
        refineProfile(pts, std::vector<float>(pts.size(), 0.003f), Eigen::Vector3d::Zero(),
                      Eigen::Vector3d::UnitZ(), box, cfg, 15, true, &eyes);
    EXPECT_TRUE(f.ok);
    return f.origin.head<2>().norm();
  };
  const double off = shift(0.0), on = shift(0.12);
  EXPECT_GT(off, 5e-4) << "the grazing points pull the joint";
  EXPECT_LT(on, 0.5 * off) << "off " << off << " m, on " << on << " m";
}

TEST(ProfileRegistration, RadiusCheckMeasuresAThinnerJointWhateverThePose) {
  // Points on the tool joint's OD (end frame z in [-0.25, -0.03]) as four cameras around it see
  // them, 3 mm depth noise along their rays. radiusOffset recovers the rendered radius minus
  // the model's within 1 mm, at the true pose and at one 3 mm and 0.5 deg off (the pose is
  // eliminated, so its error does not pass for a radius); 4.75 mm thinner is a 4.5" pipe's.
  const ToolJointDimensions dims;
  const ProfileModel box(EndLabel::kBoxEnd, dims);
  const double R = dims.tool_joint_od / 2;
  const Eigen::Vector3d origin(1.0, 2.0, 0.5);
  const Eigen::Vector3d z = Eigen::Vector3d(0.1, 0.05, 1.0).normalized();
  const Eigen::Vector3d e1 = z.unitOrthogonal(), e2 = z.cross(e1);
  for (const double delta : {0.0, -0.00475, 0.003}) {
    SCOPED_TRACE("rendered radius offset " + std::to_string(delta));
    std::mt19937 rng(7);  // fixed seed
    std::normal_distribution<double> noise(0.0, 0.003);
    std::vector<Eigen::Vector3f> pts, eyes;
    for (int c = 0; c < 4; ++c) {
      const double az = c * M_PI / 2 + 0.3;
      const Eigen::Vector3d eye = origin + 3.0 * (std::cos(az) * e1 + std::sin(az) * e2) +
                                  1.5 * Eigen::Vector3d::UnitZ();
      for (double zc = -0.25; zc <= -0.03; zc += 0.01)
        for (double phi = 0; phi < 2 * M_PI; phi += 0.08) {
          const Eigen::Vector3d radial = std::cos(phi) * e1 + std::sin(phi) * e2;
          const Eigen::Vector3d on = origin + zc * z + (R + delta) * radial;
          const Eigen::Vector3d ray = (on - eye).normalized();
          if (radial.dot(-ray) < 0.2) continue;  // facing the camera
          pts.push_back((on + noise(rng) * ray).cast<float>());
          eyes.push_back(eye.cast<float>());
        }
    }
    const std::vector<uint8_t> all(pts.size(), 1);
    const RadiusCheck at_truth = radiusOffset(box, R, origin, z, pts, eyes, all);
    ASSERT_TRUE(at_truth.ok);
    EXPECT_NEAR(at_truth.offset, delta, 0.001);
    EXPECT_GT(at_truth.std, 0.0);
    EXPECT_LT(at_truth.std, 0.001);
    EXPECT_GT(at_truth.points, pts.size() / 2);
    // Only the points whose model surface lies at most z_max along the axis count (the tube
    // below a pin end's taper, not its pin cone at the same radius); extent is their span.
    const RadiusCheck lower = radiusOffset(box, R, origin, z, pts, eyes, all, -0.15);
    ASSERT_TRUE(lower.ok);
    std::printf("delta %.4f: %zu points over %.3f m; below -0.15 m: %zu over %.3f m\n", delta,
                at_truth.points, at_truth.extent, lower.points, lower.extent);
    EXPECT_LT(lower.points, at_truth.points * 2 / 3);
    EXPECT_NEAR(at_truth.extent, 0.22, 0.01);  // the points span z -0.25 to -0.03 m
    EXPECT_NEAR(lower.extent, 0.10, 0.01);
    EXPECT_NEAR(lower.offset, delta, 0.0015);
    EXPECT_FALSE(radiusOffset(box, R, origin, z, pts, eyes, all, -0.3).ok) << "none below -0.3 m";
    const Eigen::Vector3d z_off = (z + 0.0087 * e2).normalized();  // 0.5 deg
    const RadiusCheck off_pose =
        radiusOffset(box, R, origin + 0.003 * e1, z_off, pts, eyes, all);
    ASSERT_TRUE(off_pose.ok);
    EXPECT_NEAR(off_pose.offset, delta, 0.001);
  }
  // No point on the OD: nothing measured.
  const std::vector<Eigen::Vector3f> none;
  EXPECT_FALSE(radiusOffset(box, R, origin, z, none, none, {}).ok);
}

TEST(TemporalFilter, SmoothsAStaticEndAndFollowsAMovingOneWithoutLag) {
  const uint32_t seed = 17;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double sigma = 0.005, tilt_sigma = 0.02;  // per-cycle measurement noise [m], [rad]
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();
  C.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * sigma * sigma;
  C.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * tilt_sigma * tilt_sigma;
  const int64_t period = 33333333;  // 30 Hz
  auto run = [&](const Eigen::Vector3d& velocity, double* mean_err, double* mean_along,
                 double* mean_tilt, double* raw_err) {
    EndPoseFilter f;
    double se = 0, sa = 0, st = 0, sr = 0;
    int n = 0;
    for (int k = 0; k < 300; ++k) {
      const Eigen::Vector3d truth = Eigen::Vector3d(4.7, 5.3, 1.0) + velocity * k * period * 1e-9;
      Eigen::Vector3d o = truth + sigma * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
      Eigen::Vector3d z =
          (Eigen::Vector3d::UnitZ() + tilt_sigma * Eigen::Vector3d(n01(rng), n01(rng), 0)).normalized();
      Eigen::Matrix<double, 6, 6> cov = C;
      const double raw = (o - truth).norm();
      f.update(k * period, &o, &z, &cov);
      if (k < 60) continue;  // converged after 2 s
      sr += raw;
      se += (o - truth).norm();
      if (velocity.norm() > 0) sa += (o - truth).dot(velocity.normalized());
      st += std::acos(std::min(1.0, z.z()));
      ++n;
    }
    *mean_err = se / n;
    *mean_along = sa / n;
    *mean_tilt = st / n;
    *raw_err = sr / n;
  };
  double err, along, tilt, raw;
  run(Eigen::Vector3d::Zero(), &err, &along, &tilt, &raw);
  // Unfiltered: mean 3D error ~1.6 sigma = 8 mm, mean tilt ~1.25 tilt_sigma.
  EXPECT_LT(err, 0.6 * raw) << "seed " << seed;
  EXPECT_LT(tilt, 0.4 * tilt_sigma) << "seed " << seed;
  run(Eigen::Vector3d(0, 0, -0.2), &err, &along, &tilt, &raw);
  EXPECT_LT(std::abs(along), 0.001) << "lag along the motion, seed " << seed;
  EXPECT_LT(err, 0.6 * raw) << "seed " << seed;
}

TEST(TemporalFilter, AWildFitIsHeldAndAJumpOrANewTrackIsConfirmedByTheNextMeasurement) {
  const double sigma = 0.005, tilt_sigma = 0.02;
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();
  C.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * sigma * sigma;
  C.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * tilt_sigma * tilt_sigma;
  const int64_t period = 33333333;  // 30 Hz
  const Eigen::Vector3d at(1, 2, 3), tilted = Eigen::Vector3d(0.3, 0, 1).normalized();
  auto feed = [&](EndPoseFilter& f, int k, Eigen::Vector3d o, Eigen::Vector3d z,
                  Eigen::Vector3d* out_o = nullptr, Eigen::Vector3d* out_z = nullptr) {
    Eigen::Matrix<double, 6, 6> cov = C;
    const FilterUpdate u = f.update(k * period, &o, &z, &cov);
    if (out_o) *out_o = o;
    if (out_z) *out_z = z;
    return u;
  };
  auto settled = [&](const EstimatorConfig::Temporal& cfg) {
    EndPoseFilter f(cfg);
    int k = 0;
    if (cfg.confirm_start && cfg.confirmations > 0)  // a new track's first pose: held
      EXPECT_EQ(feed(f, k++, at, Eigen::Vector3d::UnitZ()), FilterUpdate::kStarting);
    EXPECT_EQ(feed(f, k++, at, Eigen::Vector3d::UnitZ()), FilterUpdate::kRestarted);
    for (; k < 30; ++k)
      EXPECT_EQ(feed(f, k, at, Eigen::Vector3d::UnitZ()), FilterUpdate::kFiltered) << k;
    return f;
  };
  EstimatorConfig::Temporal cfg;
  ASSERT_EQ(cfg.confirmations, 1);
  {
    // One fit 17 deg off: held (not to be published), and the next normal one is filtered as if
    // it had not been there.
    EndPoseFilter f = settled(cfg);
    Eigen::Vector3d o, z;
    EXPECT_EQ(feed(f, 30, at, tilted, &o, &z), FilterUpdate::kHeld);
    EXPECT_NEAR(z.dot(tilted), 1.0, 1e-12) << "a held measurement is returned unchanged";
    EXPECT_GT(f.lastTilt(), f.lastTiltGate());
    EXPECT_EQ(feed(f, 31, at, Eigen::Vector3d::UnitZ(), &o, &z), FilterUpdate::kFiltered);
    EXPECT_GT(z.z(), std::cos(0.001)) << "the held fit did not pull the axis";
    // Two wild fits that disagree with each other confirm nothing.
    EXPECT_EQ(feed(f, 32, Eigen::Vector3d(1.5, 2, 3), Eigen::Vector3d::UnitZ()),
              FilterUpdate::kHeld);
    EXPECT_EQ(feed(f, 33, at, tilted), FilterUpdate::kHeld);
  }
  {
    // A jump of 0.5 m: held once, then confirmed by the next measurement, from which the
    // filter restarts.
    EndPoseFilter f = settled(cfg);
    Eigen::Vector3d o;
    EXPECT_EQ(feed(f, 30, Eigen::Vector3d(1.5, 2, 3), Eigen::Vector3d::UnitZ()),
              FilterUpdate::kHeld);
    EXPECT_EQ(feed(f, 31, Eigen::Vector3d(1.502, 2, 3), Eigen::Vector3d::UnitZ(), &o),
              FilterUpdate::kRestarted);
    EXPECT_NEAR(o.x(), 1.502, 1e-12);
    EXPECT_EQ(feed(f, 32, Eigen::Vector3d(1.5, 2, 3), Eigen::Vector3d::UnitZ()),
              FilterUpdate::kFiltered);
    // Time going backwards (a looped bag) starts a new track: held until the next agrees.
    EXPECT_EQ(feed(f, 0, at, Eigen::Vector3d::UnitZ()), FilterUpdate::kStarting);
    EXPECT_EQ(feed(f, 1, at, Eigen::Vector3d::UnitZ()), FilterUpdate::kRestarted);
  }
  {
    // A new track whose first fit is wild (0.5 m off) and whose next disagrees with it: nothing
    // is published until two consecutive fits agree; the filter starts from the second of them.
    EndPoseFilter f(cfg);
    Eigen::Vector3d o;
    EXPECT_EQ(feed(f, 0, Eigen::Vector3d(1.5, 2, 3), tilted), FilterUpdate::kStarting);
    EXPECT_EQ(feed(f, 1, at, Eigen::Vector3d::UnitZ()), FilterUpdate::kStarting);
    EXPECT_EQ(feed(f, 2, at + Eigen::Vector3d(0.002, 0, 0), Eigen::Vector3d::UnitZ(), &o),
              FilterUpdate::kRestarted);
    EXPECT_NEAR(o.x(), at.x() + 0.002, 1e-12);
    // With confirm_start off, the first fit is published at once (as before it existed).
    EstimatorConfig::Temporal off = cfg;
    off.confirm_start = false;
    EndPoseFilter g(off);
    EXPECT_EQ(feed(g, 0, at, Eigen::Vector3d::UnitZ()), FilterUpdate::kRestarted);
  }
  {
    // confirmations = 0: the jump restarts the filter at once.
    cfg.confirmations = 0;
    EndPoseFilter f = settled(cfg);
    Eigen::Vector3d o;
    EXPECT_EQ(feed(f, 30, Eigen::Vector3d(1.5, 2, 3), Eigen::Vector3d::UnitZ(), &o),
              FilterUpdate::kRestarted);
    EXPECT_NEAR(o.x(), 1.5, 1e-12);
  }
}

TEST(SupportPlane, RemovesAFloorRingButNotTheJointsEndFace) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::normal_distribution<double> gauss(0, 0.006);
  const double R = 0.08415;
  // A vertical joint standing 0.25 m out of a floor at z = 0, seen from all sides.
  std::vector<Eigen::Vector3f> joint, floor_ring;
  for (int i = 0; i < 600; ++i) {
    const double phi = M_PI * uni(rng), z = 0.125 * (uni(rng) + 1);
    joint.emplace_back((R + gauss(rng)) * std::cos(phi), (R + gauss(rng)) * std::sin(phi), z);
  }
  for (int i = 0; i < 60; ++i) {  // its end face annulus: narrower than plane_min_extent
    const double phi = M_PI * uni(rng), r = 0.075 + 0.009 * uni(rng);
    joint.emplace_back(r * std::cos(phi), r * std::sin(phi), 0.25 + gauss(rng));
  }
  for (int i = 0; i < 300; ++i) {
    const double phi = M_PI * uni(rng), r = R + 0.02 + 0.1 * (uni(rng) + 1);
    floor_ring.emplace_back(r * std::cos(phi), r * std::sin(phi), gauss(rng));
  }
  const EstimatorConfig::AxisFit cfg;
  EXPECT_EQ(removeSupportPlane(joint, cfg).size(), joint.size());
  std::vector<Eigen::Vector3f> all = joint;
  all.insert(all.end(), floor_ring.begin(), floor_ring.end());
  const std::vector<size_t> keep = removeSupportPlane(all, cfg);
  size_t floor_kept = 0, joint_kept = 0;
  for (size_t k : keep) (k < joint.size() ? joint_kept : floor_kept) += 1;
  EXPECT_LT(floor_kept, 15u);
  EXPECT_GT(joint_kept, joint.size() * 9 / 10);
}

TEST(SupportPlane, FindsTheLevelFloorUnderAStandingJointOnly) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::normal_distribution<double> gauss(0, 0.006);
  const double R = 0.08415, floor_z = 0.4;
  AxisLine vertical;  // through (0, 0), along z
  // A vertical joint standing 0.25 m out of a floor at floor_z, and its end face.
  std::vector<Eigen::Vector3f> joint, floor_ring;
  for (int i = 0; i < 600; ++i) {
    const double phi = M_PI * uni(rng), z = floor_z + 0.125 * (uni(rng) + 1);
    joint.emplace_back((R + gauss(rng)) * std::cos(phi), (R + gauss(rng)) * std::sin(phi), z);
  }
  for (int i = 0; i < 60; ++i) {
    const double phi = M_PI * uni(rng), r = 0.075 + 0.009 * uni(rng);
    joint.emplace_back(r * std::cos(phi), r * std::sin(phi), floor_z + 0.25 + gauss(rng));
  }
  for (int i = 0; i < 300; ++i) {
    const double phi = M_PI * uni(rng), r = R + 0.02 + 0.1 * (uni(rng) + 1);
    floor_ring.emplace_back(r * std::cos(phi), r * std::sin(phi), floor_z + gauss(rng));
  }
  const EstimatorConfig::AxisFit cfg;
  float h = -1;
  std::vector<Eigen::Vector3f> all = joint;
  all.insert(all.end(), floor_ring.begin(), floor_ring.end());
  ASSERT_TRUE(findLevelSupport(all, vertical, R, cfg, &h));
  EXPECT_NEAR(h, floor_z, 0.005);
  EXPECT_FALSE(findLevelSupport(joint, vertical, R, cfg, &h)) << "found a support at " << h;
  // The same floor at the joint's top (a joint hanging through a platform) does not hold it up.
  std::vector<Eigen::Vector3f> hanging = joint;
  for (const auto& p : floor_ring) hanging.emplace_back(p.x(), p.y(), p.z() + 0.25f);
  EXPECT_FALSE(findLevelSupport(hanging, vertical, R, cfg, &h)) << "found a support at " << h;
  // Joints in the air, lying (its top a level band, narrow across it) and tilted 26 deg below
  // the horizon (a level slice of its side is an ellipse about as wide as the joint): no support.
  for (const double tilt : {0.0, 26.0}) {
    SCOPED_TRACE("tilt " + std::to_string(tilt));
    AxisLine axis;
    axis.point = Eigen::Vector3d(0, 0, 1.5);
    axis.direction = Eigen::Vector3d(std::cos(tilt * kDeg), 0, -std::sin(tilt * kDeg));
    Eigen::Vector3d e1, e2;
    e1 = axis.direction.cross(Eigen::Vector3d::UnitY()).normalized();
    e2 = axis.direction.cross(e1);
    std::vector<Eigen::Vector3f> lying;
    for (int i = 0; i < 900; ++i) {
      const double phi = (tilt == 0.0 ? 0.5 : 1.0) * M_PI * uni(rng), s = 0.2 * uni(rng);
      const Eigen::Vector3d radial = std::cos(phi) * e1 + std::sin(phi) * e2;
      lying.push_back((axis.point + s * axis.direction + (R + gauss(rng)) *
                                                              (radial.z() < 0 ? -radial : radial))
                          .cast<float>());
    }
    EXPECT_FALSE(findLevelSupport(lying, axis, R, cfg, &h)) << "found a support at " << h;
  }
}

namespace {

struct Trial {
  EndLabel label;
  Eigen::Isometry3d T;
};

/// Runs the estimator on a rendered scene and checks the errors of every joint.
void checkScene(const Scene& scene, const std::vector<SimCamera>& cams, const RenderOptions& opt,
                double pos_tol, double angle_tol, const EstimatorConfig& cfg = testConfig(),
                bool expect_corrected = false) {
  PoseEstimator est(cfg);
  const auto inputs = renderAll(scene, cams, opt);
  const CycleResult r = est.process(inputs);
  for (const Joint& j : scene.joints) {
    const EndEstimate& e = r.end(j.label);
    SCOPED_TRACE(describe(e));
    ASSERT_TRUE(e.valid);
    EXPECT_EQ(e.label, j.label);
    EXPECT_EQ(e.label_corrected, expect_corrected);
    const PoseError err = poseError(j.T_world_end, e.T_world_end);
    EXPECT_LT(err.position_norm, pos_tol)
        << "along " << err.along_axis << " across " << err.across_axis;
    EXPECT_LT(err.axis_angle, angle_tol);
    EXPECT_LT(positionMahalanobis2(e, j.T_world_end), 3.0 * 3.0 * 3.0);  // well inside 3-sigma^2*3
    // Roll canonical.
    EXPECT_LT((e.T_world_end.linear() - canonicalRotation(e.T_world_end.linear().col(2))).norm(),
              1e-9);
  }
}

}  // namespace

TEST(PoseEstimator, CleanVerticalBoxAndPin) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({4.694, 5.3, 1.23}, {0, 0, 1})));
  scene.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt({4.694, 6.8, 1.327}, {0, 0, 1})));
  checkScene(scene, ring({5, 5, 1.0}, 5.5, 4.5), {}, 0.004, 0.3 * kDeg);
}

TEST(PoseEstimator, ANewTracksFirstPoseIsHeldUntilTheNextAgrees) {
  // The default temporal filter (confirm_start): an end's first fit is not published alone; the
  // next cycle's, agreeing with it, is. After a gap longer than temporal.max_gap the end is a
  // new track again.
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({4.694, 5.3, 1.23}, {0, 0, 1})));
  const auto inputs = renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), {});
  EstimatorConfig cfg = testConfig();
  cfg.temporal.confirm_start = EstimatorConfig::Temporal().confirm_start;
  ASSERT_TRUE(cfg.temporal.confirm_start);
  PoseEstimator est(cfg);
  auto at = [&](int64_t stamp_ns) {
    auto in = inputs;
    for (auto& i : in) i.frame.stamp_ns = stamp_ns;
    return est.process(in).end(EndLabel::kBoxEnd);
  };
  const int64_t t0 = 1000000000LL, period = 33000000LL;
  EndEstimate e = at(t0);
  EXPECT_FALSE(e.valid);
  EXPECT_NE(e.reason.find("a new track's first pose"), std::string::npos) << e.reason;
  e = at(t0 + period);
  EXPECT_TRUE(e.valid) << describe(e);
  EXPECT_TRUE(at(t0 + 2 * period).valid);
  const int64_t later = t0 + 2 * period + static_cast<int64_t>(2e9 * cfg.temporal.max_gap);
  e = at(later);
  EXPECT_FALSE(e.valid) << "after a gap";
  EXPECT_NE(e.reason.find("a new track's first pose"), std::string::npos) << e.reason;
  EXPECT_TRUE(at(later + period).valid);
}

TEST(PoseEstimator, CovarianceAddsTheRigCalibrationUncertainty) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({4.694, 5.3, 1.23}, {0, 0, 1})));
  // Six cameras 5.5 m around (5, 5) at 4.5 m: 6.0-6.8 m from the end.
  const auto inputs = renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), {});
  EstimatorConfig exact = testConfig();
  exact.covariance.extrinsic_translation_std = 0.0;
  exact.covariance.extrinsic_rotation_std = 0.0;
  const EstimatorConfig field = testConfig();  // the defaults: 5 mm, 0.2 deg
  const double t = field.covariance.extrinsic_translation_std;
  const double r = field.covariance.extrinsic_rotation_std;
  ASSERT_GT(t, 0.0);
  ASSERT_GT(r, 0.0);
  PoseEstimator a(exact), b(field);
  const EndEstimate ea = a.process(inputs).end(EndLabel::kBoxEnd);
  const EndEstimate eb = b.process(inputs).end(EndLabel::kBoxEnd);
  ASSERT_TRUE(ea.valid) << describe(ea);
  ASSERT_TRUE(eb.valid) << describe(eb);
  // The same pose; only the covariance grows.
  EXPECT_TRUE(ea.T_world_end.isApprox(eb.T_world_end, 1e-12));
  const double n = static_cast<double>(eb.cameras.size());
  ASSERT_GT(n, 0.0);
  const Eigen::Matrix<double, 6, 6> d = eb.covariance - ea.covariance;
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(d(k, k), (t * t + std::pow(r * 6.0, 2)) / n) << "position " << k;
    EXPECT_LE(d(k, k), (t * t + std::pow(r * 6.8, 2)) / n) << "position " << k;
  }
  // Tilt about x and y, nothing about the (vertical) axis.
  for (int k = 3; k < 5; ++k) {
    EXPECT_GE(d(k, k), r * r / n) << "rotation " << k;
    EXPECT_LE(d(k, k), (r * r + t * t / 0.01) / n) << "rotation " << k;
  }
  EXPECT_NEAR(d(5, 5), 0.0, 1e-12);
}

TEST(PoseEstimator, NoisyRandomPoses) {
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> uni(-1, 1);
    SCOPED_TRACE("seed " + std::to_string(seed));
    Scene scene;
    for (EndLabel l : {EndLabel::kBoxEnd, EndLabel::kPinEnd}) {
      const Eigen::Vector3d z = Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized();
      const Eigen::Vector3d o(5 + 0.5 * uni(rng) + (l == EndLabel::kPinEnd ? 1.2 : -0.5),
                              5 + uni(rng), 1.5 + 0.3 * uni(rng));
      scene.joints.push_back(makeJoint(l, poseAt(o, z)));
    }
    RenderOptions opt;
    opt.noise_scale = 1.0;
    opt.box_jitter_px = 3.0;
    opt.seed = seed;
    checkScene(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt, 0.012, 1.0 * kDeg);
  }
}

TEST(PoseEstimator, WornJointsPositionRestsOnTheShoulder) {
  ToolJointDimensions worn;
  worn.tool_joint_od -= 0.002;
  worn.box_tong_length -= 0.020;
  worn.pin_tong_length -= 0.020;
  Scene scene;
  scene.joints.push_back(
      makeJoint(EndLabel::kBoxEnd, poseAt({4.7, 5.3, 1.3}, {0.5, 0, 0.866}), worn));
  scene.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt({4.7, 6.8, 1.3}, {0, 0, 1}), worn));
  RenderOptions opt;
  opt.noise_scale = 1.0;
  checkScene(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt, 0.008, 1.0 * kDeg);
}

TEST(PoseEstimator, HorizontalAndHangingWithClutterAndOneCamera) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt({5.0, 5.0, 1.5}, {1, 0.3, 0})));
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({5.8, 6.5, 2.0}, {0, 0, -1})));
  scene.posts.push_back({Eigen::Vector2d(5.0, 5.4), 0.08, 0.0, 2.2});
  scene.posts.push_back({Eigen::Vector2d(6.2, 6.5), 0.1, 0.0, 3.0});
  RenderOptions opt;
  opt.noise_scale = 1.0;
  opt.box_jitter_px = 2.0;
  checkScene(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt, 0.015, 1.5 * kDeg);
  // One camera only.
  Scene single;
  single.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({5, 5, 1.2}, {0.3, 0, 0.95})));
  checkScene(single, {ring({5, 5, 1.0}, 5.5, 4.5)[0]}, opt, 0.025, 3.0 * kDeg);
}

TEST(PoseEstimator, TracksBetweenFullDecisionsAndRedecidesAfterAJump) {
  // Cycles 33 ms apart: the first decides, the next ones follow the track until
  // tracking.redecide_every; a joint that jumps 0.3 m breaks the track (a full decision, no
  // wrong pose); tracking off decides every cycle.
  for (const bool enabled : {true, false}) {
    SCOPED_TRACE(enabled ? "tracking on" : "tracking off");
    EstimatorConfig cfg = testConfig();
    cfg.tracking.enabled = enabled;
    cfg.temporal.enabled = false;  // the raw per-cycle poses are checked
    PoseEstimator est(cfg);
    const int n = cfg.tracking.redecide_every + 3;
    for (int k = 0; k < n; ++k) {
      SCOPED_TRACE("cycle " + std::to_string(k));
      const bool jumped = k >= n - 2;
      Scene scene;
      scene.joints.push_back(makeJoint(
          EndLabel::kBoxEnd, poseAt({4.694, 5.3 + (jumped ? 0.3 : 0.0), 1.23}, {0, 0, 1})));
      RenderOptions opt;
      opt.noise_scale = 1.0;
      opt.seed = 100 + k;
      auto inputs = renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt);
      for (auto& in : inputs) in.frame.stamp_ns = 1000000000LL + k * 33000000LL;
      const CycleResult r = est.process(inputs);
      const EndEstimate& e = r.end(EndLabel::kBoxEnd);
      ASSERT_TRUE(e.valid) << describe(e);
      const PoseError err = poseError(scene.joints[0].T_world_end, e.T_world_end);
      EXPECT_LT(err.position_norm, 0.012) << describe(e);
      EXPECT_LT(err.axis_angle, 1.0 * kDeg) << describe(e);
      // Decisions: cycle 0, cycle redecide_every, and the jump's first cycle.
      const bool decides =
          !enabled || k == 0 || k == cfg.tracking.redecide_every || k == n - 2;
      EXPECT_EQ(e.tracked, !decides) << describe(e);
    }
  }
}

TEST(PoseEstimator, AnotherPipeSizesEndIsNotTakenAndTwoAlikeGiveNoPose) {
  // A 5" box end and, 1.5 m away, the box end of a 4.5" pipe, both detected as box_end: after
  // instances.min_decisions cycles the 5" one is chosen and kept. Two 5" ones whose costs differ
  // by less than instances.min_cost_margin (0.3 here: the second is partly hidden by the first
  // from one camera, and fits ~12 % worse): no pose, and the reason names both places.
  ToolJointDimensions small;
  small.tool_joint_od = 0.1588;
  small.tube_od = 0.1143;
  small.box_counterbore_diameter = small.box_counterbore_diameter - 0.01;
  // The pin still enters the counterbore (validateDimensions): Qc = DL + 1/16" as the API NC
  // connections (Spec 7-2 Table B.1).
  small.pin_large_diameter = small.box_counterbore_diameter - 0.0016;
  const Eigen::Isometry3d T_a = poseAt({4.5, 5.3, 1.23}, {0, 0, 1});
  for (const bool same : {false, true}) {
    SCOPED_TRACE(same ? "two 5 inch" : "5 inch and 4.5 inch");
    Scene scene;
    scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, T_a));
    scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({5.6, 4.3, 1.23}, {0, 0, 1}),
                                     same ? ToolJointDimensions() : small));
    EstimatorConfig cfg = testConfig();
    cfg.temporal.enabled = false;
    if (same) cfg.instances.min_cost_margin = 0.3;
    PoseEstimator est(cfg);
    const int n = cfg.instances.min_decisions + 3;
    for (int k = 0; k < n; ++k) {
      SCOPED_TRACE("cycle " + std::to_string(k));
      RenderOptions opt;
      opt.noise_scale = 1.0;
      opt.seed = 300 + k;
      auto inputs = renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt);
      for (auto& in : inputs) in.frame.stamp_ns = 1000000000LL + k * 33000000LL;
      // (The result is kept: a reference into the temporary would dangle - found by ASan.)
      const CycleResult r = est.process(inputs);
      const EndEstimate& e = r.end(EndLabel::kBoxEnd);
      if (k < cfg.instances.min_decisions - 1) {
        EXPECT_FALSE(e.valid) << describe(e);
        EXPECT_NE(e.reason.find("not choosing yet"), std::string::npos) << e.reason;
      } else if (same) {
        EXPECT_FALSE(e.valid) << describe(e);
        EXPECT_NE(e.reason.find("fit alike"), std::string::npos) << e.reason;
        size_t places = 0;
        for (size_t i = e.reason.find(" at ("); i != std::string::npos;
             i = e.reason.find(" at (", i + 1))
          ++places;
        EXPECT_EQ(places, 2u) << e.reason;
      } else {
        ASSERT_TRUE(e.valid) << describe(e);
        EXPECT_LT(poseError(T_a, e.T_world_end).position_norm, 0.012) << describe(e);
      }
    }
  }
}

TEST(PoseEstimator, SwappedLabelsAreCorrectedByGeometry) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({4.694, 5.3, 1.23}, {0, 0, 1})));
  scene.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt({4.694, 6.8, 1.327}, {0, 0, 1})));
  RenderOptions opt;
  opt.noise_scale = 1.0;
  opt.swap_labels = true;
  checkScene(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt, 0.01, 1.0 * kDeg, testConfig(), true);
  // A single swapped end: the pin's points are moved to the pin slot; the box slot is empty.
  Scene one;
  one.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt({5, 5, 1.3}, {0, 0, 1})));
  PoseEstimator est(testConfig());
  const CycleResult r = est.process(renderAll(one, ring({5, 5, 1.0}, 5.5, 4.5), opt));
  EXPECT_TRUE(r.end(EndLabel::kPinEnd).valid) << describe(r.end(EndLabel::kPinEnd));
  EXPECT_TRUE(r.end(EndLabel::kPinEnd).label_corrected);
  EXPECT_FALSE(r.end(EndLabel::kBoxEnd).valid);
  EXPECT_NE(r.end(EndLabel::kBoxEnd).reason.find("label corrected"), std::string::npos)
      << r.end(EndLabel::kBoxEnd).reason;
}

TEST(PoseEstimator, ALabelFlipAgainstItsTrackWaitsForDecisionsInARow) {
  // A pin end tracked for three cycles; then cycles whose points are a box end's, still
  // detected as pin_end (one dark cycle's misfit, or the joint really is a box end).
  const Eigen::Isometry3d T = poseAt({5, 5, 1.3}, {0, 0, 1});
  Scene pin, box;
  pin.joints.push_back(makeJoint(EndLabel::kPinEnd, T));
  box.joints.push_back(makeJoint(EndLabel::kBoxEnd, T));
  const auto cams = ring({5, 5, 1.0}, 5.5, 4.5);
  RenderOptions swapped;
  swapped.swap_labels = true;
  const auto pin_inputs = renderAll(pin, cams, {});
  const auto box_inputs = renderAll(box, cams, swapped);
  EstimatorConfig cfg = testConfig();
  cfg.tracking.redecide_every = 1;  // every cycle decides (on the track's axis)
  ASSERT_EQ(cfg.instances.min_decisions, 3);
  PoseEstimator est(cfg);
  int k = 0;
  auto cycle = [&](const std::vector<CameraInput>& inputs) {
    auto in = inputs;
    for (auto& i : in) i.frame.stamp_ns = 1000000000LL + (k++) * 33000000LL;
    return est.process(in);
  };
  for (int i = 0; i < 3; ++i) {
    const CycleResult r = cycle(pin_inputs);
    ASSERT_TRUE(r.end(EndLabel::kPinEnd).valid) << describe(r.end(EndLabel::kPinEnd));
  }
  // One flipped decision: nothing is published; a pin decision after it resets the count.
  CycleResult r = cycle(box_inputs);
  EXPECT_FALSE(r.end(EndLabel::kPinEnd).valid);
  EXPECT_FALSE(r.end(EndLabel::kBoxEnd).valid) << describe(r.end(EndLabel::kBoxEnd));
  EXPECT_NE(r.end(EndLabel::kPinEnd).reason.find("against their last fit (1 of 3"),
            std::string::npos)
      << r.end(EndLabel::kPinEnd).reason;
  r = cycle(pin_inputs);
  EXPECT_TRUE(r.end(EndLabel::kPinEnd).valid) << describe(r.end(EndLabel::kPinEnd));
  // Three in a row: the third corrects the label.
  for (int i = 1; i <= 2; ++i) {
    r = cycle(box_inputs);
    EXPECT_FALSE(r.end(EndLabel::kBoxEnd).valid) << "flip " << i;
    EXPECT_NE(r.end(EndLabel::kPinEnd).reason.find("(" + std::to_string(i) + " of 3"),
              std::string::npos)
        << r.end(EndLabel::kPinEnd).reason;
  }
  r = cycle(box_inputs);
  ASSERT_TRUE(r.end(EndLabel::kBoxEnd).valid) << describe(r.end(EndLabel::kBoxEnd));
  EXPECT_TRUE(r.end(EndLabel::kBoxEnd).label_corrected);
  EXPECT_LT(poseError(T, r.end(EndLabel::kBoxEnd).T_world_end).position_norm, 0.01);
}

TEST(PoseEstimator, EmptyInputAndNoBoxesGiveReasons) {
  PoseEstimator est(testConfig());
  CycleResult r = est.process({});
  for (const auto& e : r.ends) {
    EXPECT_FALSE(e.valid);
    EXPECT_FALSE(e.reason.empty());
  }
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({5, 5, 1.2}, {0, 0, 1})));
  auto inputs = renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), {});
  for (auto& in : inputs) in.frame.boxes.clear();
  // A bad camera is skipped and named; the others go on.
  inputs[1].frame.depth_info.P[0] = std::nan("");
  r = est.process(inputs);
  for (const auto& e : r.ends) {
    EXPECT_FALSE(e.valid);
    EXPECT_NE(e.reason.find("detection"), std::string::npos) << e.reason;
  }
  ASSERT_EQ(r.camera_errors.size(), 1u);
  EXPECT_NE(r.camera_errors[0].find("cam2"), std::string::npos) << r.camera_errors[0];
}

TEST(PoseEstimator, ATransformThatIsNotRigidIsRefusedNamingTheCamera) {
  // A TF of arbitrary numbers (found by the sensor_frame_cutout fuzz harness: a finite 4x4 with
  // entries of 1e305 turned every cut-out point into NaN) is refused with the camera and the
  // transform named; the other cameras go on.
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({5, 5, 1.2}, {0, 0, 1})));
  auto inputs = renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), {});
  inputs[1].T_world_depth.matrix()(0, 1) = 1.7e296;  // rotation no longer orthonormal
  inputs[2].T_world_depth.translation().x() = 1e7;    // 10 000 km away
  inputs[3].T_color_depth.linear() *= 1.01;           // a scale, not a rotation
  PoseEstimator est(testConfig());
  const CycleResult r = est.process(inputs);
  ASSERT_EQ(r.camera_errors.size(), 3u);
  EXPECT_NE(r.camera_errors[0].find("cam2: T_world_depth is not a rigid transform"),
            std::string::npos)
      << r.camera_errors[0];
  EXPECT_NE(r.camera_errors[1].find("cam3: T_world_depth translation"), std::string::npos)
      << r.camera_errors[1];
  EXPECT_NE(r.camera_errors[2].find("cam4: T_color_depth is not a rigid transform"),
            std::string::npos)
      << r.camera_errors[2];
  EXPECT_EQ(r.cameras_used.size(), inputs.size() - 3);
}

TEST(PoseEstimator, TimingSixCameras) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({4.694, 5.3, 1.23}, {0, 0, 1})));
  scene.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt({4.694, 6.8, 1.327}, {0, 0, 1})));
  RenderOptions opt;
  opt.noise_scale = 1.0;
  const auto inputs = renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt);
  PoseEstimator est(testConfig());
  std::vector<double> ms;
  for (int i = 0; i < 20; ++i) ms.push_back(est.process(inputs).timing.total_ms);
  const CycleResult r = est.process(inputs);
  std::printf("six-camera cycle: median %.2f ms (cutout %.2f fusion %.2f seg %.2f reg %.2f)\n",
              percentile(ms, 0.5), r.timing.cutout_ms, r.timing.fusion_ms, r.timing.segmentation_ms,
              r.timing.registration_ms);
  // Speed is measured by scripts/bench, not asserted here (shared, noisy machines).
  EXPECT_TRUE(r.end(EndLabel::kBoxEnd).valid || r.end(EndLabel::kPinEnd).valid);
}

TEST(ThesisBaseline, RunsTheThesisStepsOnAVerticalPipe) {
  Scene scene;
  scene.joints.push_back(makeJoint(EndLabel::kBoxEnd, poseAt({4.694, 5.3, 1.23}, {0, 0, 1})));
  scene.joints.push_back(makeJoint(EndLabel::kPinEnd, poseAt({4.694, 6.8, 1.327}, {0, 0, 1})));
  RenderOptions opt;
  opt.noise_scale = 1.0;
  EstimatorConfig cfg = testConfig();
  cfg.method = EstimatorMethod::kThesisBaseline;
  cfg.baseline.icp_runs = 2;  // keep the test fast (the thesis: 10 x 200)
  cfg.baseline.icp_iterations = 25;
  PoseEstimator est(cfg);
  CycleResult r;
  for (uint32_t k = 0; k < 3; ++k) {
    opt.seed = k + 1;
    r = est.process(renderAll(scene, ring({5, 5, 1.0}, 5.5, 4.5), opt));
  }
  for (const Joint& j : scene.joints) {
    const EndEstimate& e = r.end(j.label);
    SCOPED_TRACE(describe(e));
    ASSERT_TRUE(e.valid);
    const PoseError err = poseError(j.T_world_end, e.T_world_end);
    std::printf("baseline %s: position error %.1f mm, axis %.2f deg, %.1f ms\n", labelName(j.label),
                err.position_norm * 1000, err.axis_angle / kDeg, r.timing.total_ms);
    EXPECT_LT(err.position_norm, 0.15);
  }
}
