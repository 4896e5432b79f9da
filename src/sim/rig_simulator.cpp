#include "drill_pipe_pose/sim/rig_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "drill_pipe_pose/sim/depth_effects.hpp"
#include "drill_pipe_pose/sim/random.hpp"

namespace drill_pipe_pose::sim {

namespace {

CameraInfoData makeInfo(const PinholeCamera& cam, const std::string& frame) {
  CameraInfoData info;
  info.frame_id = frame;
  info.width = cam.sensorWidth();
  info.height = cam.sensorHeight();
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {cam.fx(), 0, cam.cx(), 0, cam.fy(), cam.cy(), 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {cam.fx(), 0, cam.cx(), 0, 0, cam.fy(), cam.cy(), 0, 0, 0, 1, 0};
  return info;
}

/// The colour camera at `scale` times its resolution: focal lengths and centre x scale. The
/// built-in Kinect v2 QHD model (c = 479.75, 269.75) is the HD calibration (959.5, 539.5) halved,
/// so x 2 gives the HD image's own values back ((c + 0.5) 2 - 0.5 would give 960.0, 540.0).
PinholeCamera scaledColor(const PinholeCamera& c, int scale) {
  if (scale < 1 || scale > 8) fail("SimulatorOptions: color_scale = ", scale, ": expected 1..8");
  if (c.offsetX() != 0 || c.offsetY() != 0 || c.imageWidth() != c.sensorWidth())
    fail("SimulatorOptions: color_scale = ", scale, ": the colour model is cropped");
  const double s = scale;
  return PinholeCamera::fromIntrinsics(c.sensorWidth() * scale, c.sensorHeight() * scale,
                                       c.fx() * s, c.fy() * s, c.cx() * s, c.cy() * s);
}

/// A random unit vector.
Eigen::Vector3d randomDirection(Rng& rng) {
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
  } while (v.norm() < 1e-6);
  return v.normalized();
}

/// Pixel rectangle [u0, u1] x [v0, v1] covering the projection of a world box; the whole image
/// when the box reaches behind the camera. False when it is entirely outside the image.
bool projectBounds(const Eigen::AlignedBox3d& box_world, const Eigen::Isometry3d& T_cam_world,
                   const PinholeCamera& cam, int* u0, int* v0, int* u1, int* v1) {
  const int W = static_cast<int>(cam.imageWidth()), H = static_cast<int>(cam.imageHeight());
  double a0 = 1e18, b0 = 1e18, a1 = -1e18, b1 = -1e18;
  bool behind = false, all_behind = true;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d c((i & 1) ? box_world.max().x() : box_world.min().x(),
                            (i & 2) ? box_world.max().y() : box_world.min().y(),
                            (i & 4) ? box_world.max().z() : box_world.min().z());
    const Eigen::Vector3d p = T_cam_world * c;
    if (p.z() < 0.05) {
      behind = true;
      continue;
    }
    all_behind = false;
    Eigen::Vector2d uv = Eigen::Vector2d::Zero();
    cam.project(p, &uv);
    a0 = std::min(a0, uv.x());
    b0 = std::min(b0, uv.y());
    a1 = std::max(a1, uv.x());
    b1 = std::max(b1, uv.y());
  }
  if (all_behind) return false;
  if (behind) {
    *u0 = 0;
    *v0 = 0;
    *u1 = W - 1;
    *v1 = H - 1;
    return true;
  }
  *u0 = std::max(0, static_cast<int>(std::floor(a0)) - 1);
  *v0 = std::max(0, static_cast<int>(std::floor(b0)) - 1);
  *u1 = std::min(W - 1, static_cast<int>(std::ceil(a1)) + 1);
  *v1 = std::min(H - 1, static_cast<int>(std::ceil(b1)) + 1);
  return *u0 <= *u1 && *v0 <= *v1;
}

}  // namespace

/// Per-camera state: geometry, seeded setup, cached static background and work buffers.
struct RigSimulator::Camera {
  std::string name;
  std::string sensor_key;  ///< the rig file's `sensor`
  SensorIntrinsics sensor;
  Eigen::Isometry3d T_world_link_true, T_world_link_pub, T_world_depth, T_world_color;
  CameraInfoData color_info, depth_info;
  double depth_offset = 0.0;          ///< [m]
  double depth_scale = 1.0;           ///< depth x this
  double phase = 0.0;                 ///< [s]
  std::vector<Eigen::Vector3f> rays;  ///< unit ray of each depth pixel, depth optical frame
  std::vector<float> ray_z;           ///< their z components (range = depth / ray_z)
  // Static background of the depth image, per pixel (z = 0: no return).
  bool depth_ready = false;
  std::vector<float> bg_z;     ///< [m] along the optical axis
  std::vector<float> bg_cos;   ///< cos(incidence)
  std::vector<float> bg_refl;  ///< reflectivity
  std::vector<float> bg_g2;    ///< incidence term of the noise model
  // Static background of the colour image.
  bool color_ready = false;
  std::vector<uint8_t> bg_bgr;  ///< shaded, noise-free
  std::vector<float> bg_t;      ///< [m] ray distance (1e9: nothing)
  // Work buffers.
  std::vector<float> z, cosv, refl, g2;
  std::vector<uint8_t> bgr;
  std::vector<float> ct;
};

RigSimulator::RigSimulator(const RigCalibration& rig, const SceneConfig& scene,
                           const SimulatorOptions& opt)
    : world_frame_(rig.world_frame),
      scene_config_(scene),
      opt_(opt),
      fx_(opt.effects ? *opt.effects : sensorProfile(opt.profile)),
      detector_(opt.detector) {
  if (rig.cameras.empty()) fail("RigSimulator: the rig has no cameras");
  scene_ = buildScene(scene, fx_, opt.seed);
  for (size_t i = 0; i < scene_.objects.size(); ++i)
    (scene_.isDynamic(i) ? dynamic_objects_ : static_objects_).push_back(static_cast<int>(i));
  std::map<std::string, SensorIntrinsics> sensors;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const CameraCalibration& cc = rig.cameras[i];
    auto cam = std::make_unique<Camera>();
    cam->name = cc.name;
    if (!sensors.count(cc.sensor)) {
      if (!opt.sensor_config_dir.empty())
        sensors[cc.sensor] =
            loadSensorIntrinsics(opt.sensor_config_dir + "/" + cc.sensor + ".yaml");
      else if (cc.sensor == "kinect_v2")
        sensors[cc.sensor] = SensorIntrinsics::kinectV2();
      else
        fail("RigSimulator: camera ", cc.name, ": sensor \"", cc.sensor,
             "\" needs SimulatorOptions::sensor_config_dir (only kinect_v2 is built in)");
    }
    cam->sensor = sensors[cc.sensor];
    cam->sensor_key = cc.sensor;
    if (opt.color_scale != 1) cam->sensor.color = scaledColor(cam->sensor.color, opt.color_scale);
    cam->T_world_link_true = cc.T_world_link;
    // Seeded per-camera setup; all numbers drawn in a fixed order whatever the switches.
    Rng rng(streamSeed(opt.seed, kStreamCameraSetup, i));
    const double period = 1.0 / cam->sensor.frame_rate_hz;
    const double phase = rng.uniform(0.0, period);
    const double offset = rng.uniform(-1.0, 1.0) * fx_.max_depth_offset;
    const Eigen::Vector3d dt = randomDirection(rng) * fx_.calib_translation_error;
    const Eigen::Vector3d axis = randomDirection(rng);
    cam->phase = fx_.unsynchronised ? phase : 0.0;
    cam->depth_offset = fx_.depth_offset ? offset : 0.0;
    // The scale from its own stream, so that the draws above stay as they were.
    Rng scale_rng(streamSeed(opt.seed, kStreamDepthScale, i));
    const double scale = 1.0 + scale_rng.uniform(-1.0, 1.0) * fx_.max_depth_scale_error;
    cam->depth_scale = fx_.depth_scale ? scale : 1.0;
    cam->T_world_link_pub = cam->T_world_link_true;
    if (fx_.calibration_error) {
      Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
      delta.linear() =
          Eigen::AngleAxisd(fx_.calib_rotation_error_deg * M_PI / 180.0, axis).toRotationMatrix();
      delta.translation() = dt;
      cam->T_world_link_pub = cam->T_world_link_true * delta;
    }
    cam->T_world_color = cam->T_world_link_true;  // <cam>_link == <cam>_rgb_optical_frame
    cam->T_world_depth = cam->T_world_link_true * cam->sensor.T_color_depth;
    cam->color_info = makeInfo(cam->sensor.color, conventions::colorOpticalFrame(cc.name));
    cam->depth_info = makeInfo(cam->sensor.depth, conventions::depthOpticalFrame(cc.name));
    const PinholeCamera& d = cam->sensor.depth;
    cam->rays.resize(static_cast<size_t>(d.imageWidth()) * d.imageHeight());
    for (uint32_t v = 0; v < d.imageHeight(); ++v)
      for (uint32_t u = 0; u < d.imageWidth(); ++u)
        cam->rays[v * d.imageWidth() + u] =
            Eigen::Vector3f(static_cast<float>((u + d.offsetX() - d.cx()) / d.fx()),
                            static_cast<float>((v + d.offsetY() - d.cy()) / d.fy()), 1.0f)
                .normalized();
    cam->ray_z.resize(cam->rays.size());
    for (size_t k = 0; k < cam->rays.size(); ++k) cam->ray_z[k] = cam->rays[k].z();
    cams_.push_back(std::move(cam));
  }
  for (const CameraBump& b : opt.bumps) {
    bool known = false;
    for (const auto& c : cams_) known = known || c->name == b.camera;
    if (!known) fail("RigSimulator: camera bump of \"", b.camera, "\": no such camera in the rig");
  }
}

RigSimulator::~RigSimulator() = default;

Eigen::Isometry3d CameraBump::delta() const {
  const double k = M_PI / 180.0;
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  d.translation() = translation;
  d.linear() = (Eigen::AngleAxisd(rpy_deg.z() * k, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(rpy_deg.y() * k, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rpy_deg.x() * k, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return d;
}

CameraBump parseCameraBump(const std::string& text) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (size_t colon; (colon = text.find(':', start)) != std::string::npos; start = colon + 1)
    parts.push_back(text.substr(start, colon - start));
  parts.push_back(text.substr(start));
  auto bad = [&](const std::string& why) {
    fail("camera bump \"", text, "\": ", why,
         " (expected CAM:T:DX,DY,DZ[:ROLL,PITCH,YAW] in s, m, deg)");
  };
  if (parts.size() < 3 || parts.size() > 4 || parts[0].empty()) bad("wrong number of fields");
  auto number = [&](const std::string& f) {
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(f, &used);
    } catch (const std::exception&) {
      bad("\"" + f + "\" is not a number");
    }
    if (used != f.size() || !std::isfinite(v)) bad("\"" + f + "\" is not a number");
    return v;
  };
  auto triple = [&](const std::string& f) {
    const size_t a = f.find(','), b = a == std::string::npos ? a : f.find(',', a + 1);
    if (b == std::string::npos || f.find(',', b + 1) != std::string::npos)
      bad("\"" + f + "\" is not three comma-separated numbers");
    return Eigen::Vector3d(number(f.substr(0, a)), number(f.substr(a + 1, b - a - 1)),
                           number(f.substr(b + 1)));
  };
  CameraBump bump;
  bump.camera = parts[0];
  bump.t = number(parts[1]);
  bump.translation = triple(parts[2]);
  if (parts.size() == 4) bump.rpy_deg = triple(parts[3]);
  return bump;
}

void RigSimulator::applyBumps(Camera& cam, double t) {
  const CameraBump* due = nullptr;
  for (const CameraBump& b : opt_.bumps)
    if (b.camera == cam.name && b.t <= t && (!due || b.t >= due->t)) due = &b;
  const Eigen::Isometry3d T_world_link =
      due ? Eigen::Isometry3d(cam.T_world_link_true * due->delta()) : cam.T_world_link_true;
  if (T_world_link.matrix() == cam.T_world_color.matrix()) return;
  cam.T_world_color = T_world_link;
  cam.T_world_depth = T_world_link * cam.sensor.T_color_depth;
  cam.depth_ready = false;
  cam.color_ready = false;
}

const std::string& RigSimulator::cameraName(size_t i) const {
  return cams_.at(i)->name;
}
Eigen::Isometry3d RigSimulator::publishedT_world_link(size_t i) const {
  return cams_.at(i)->T_world_link_pub;
}
Eigen::Isometry3d RigSimulator::trueT_world_link(size_t i) const {
  return cams_.at(i)->T_world_link_true;
}
Eigen::Isometry3d RigSimulator::T_link_depth(size_t i) const {
  return cams_.at(i)->sensor.T_color_depth;
}
const CameraInfoData& RigSimulator::colorInfo(size_t i) const {
  return cams_.at(i)->color_info;
}
const CameraInfoData& RigSimulator::depthInfo(size_t i) const {
  return cams_.at(i)->depth_info;
}
double RigSimulator::depthOffset(size_t i) const {
  return cams_.at(i)->depth_offset;
}
double RigSimulator::depthScale(size_t i) const {
  return cams_.at(i)->depth_scale;
}
double RigSimulator::effectiveDepthOffset(size_t i) const {
  // z_meas = (z + noise + bias) * scale + offset: the bias enters scaled.
  return depthOffset(i) + depthScale(i) * static_cast<double>(brightnessBias(fx_, 0.0f));
}
RigCalibration RigSimulator::trueRig() const {
  RigCalibration rig;
  rig.world_frame = world_frame_;
  for (size_t i = 0; i < cams_.size(); ++i) {
    CameraCalibration c;
    c.name = cams_[i]->name;
    c.T_world_link = trueT_world_link(i);
    c.sensor = cams_[i]->sensor_key;
    c.depth_offset = effectiveDepthOffset(i);
    c.depth_scale = depthScale(i);
    rig.cameras.push_back(c);
  }
  return rig;
}
const SensorIntrinsics& RigSimulator::sensor(size_t i) const {
  return cams_.at(i)->sensor;
}

int64_t RigSimulator::stampNs(double t) const {
  return opt_.stamp_origin_ns + static_cast<int64_t>(std::llround(t * 1e9));
}

double RigSimulator::captureTime(size_t i, uint64_t k) const {
  const Camera& cam = *cams_.at(i);
  double t = cam.phase + static_cast<double>(k) / cam.sensor.frame_rate_hz;
  if (fx_.unsynchronised && fx_.clock_jitter_sigma > 0) {
    Rng rng(streamSeed(opt_.seed, kStreamClockJitter, i, k));
    t += fx_.clock_jitter_sigma * std::clamp(rng.normal(), -3.0, 3.0);
  }
  return t;
}

std::vector<Capture> RigSimulator::captures(double t0, double t1) const {
  std::vector<Capture> out;
  for (size_t i = 0; i < cams_.size(); ++i) {
    const double rate = cams_[i]->sensor.frame_rate_hz;
    const double k0 = std::floor((t0 - cams_[i]->phase) * rate) - 1;
    for (uint64_t k = static_cast<uint64_t>(std::max(0.0, k0));; ++k) {
      const double t = captureTime(i, k);
      if (t >= t1) break;
      if (t >= t0) out.push_back({t, i, k});
    }
  }
  std::sort(out.begin(), out.end(), [](const Capture& a, const Capture& b) {
    return a.t < b.t || (a.t == b.t && a.camera < b.camera);
  });
  return out;
}

std::vector<std::pair<double, size_t>> RigSimulator::captureSchedule(double t0, double t1) const {
  std::vector<std::pair<double, size_t>> out;
  for (const Capture& c : captures(t0, t1)) out.emplace_back(c.t, c.camera);
  return out;
}

std::vector<RigSimulator::TruthEnd> RigSimulator::groundTruth(double t) const {
  std::vector<TruthEnd> out;
  for (size_t i = 0; i < scene_.ends.size(); ++i)
    if (scene_.ends[i].ground_truth)
      out.push_back({scene_.ends[i].label, scene_.ends[i].pipe,
                     canonicalize(scene_.endPose(i, t)), scene_.ends[i].nominal.tool_joint_od,
                     scene_.ends[i].rendered.tool_joint_od});
  return out;
}

void RigSimulator::ensureBackground(Camera& cam) {
  if (cam.depth_ready) return;
  const SceneSnapshot snap = scene_.snapshot(0.0);
  const size_t n = cam.rays.size();
  cam.bg_z.assign(n, 0.0f);
  cam.bg_cos.assign(n, 0.0f);
  cam.bg_refl.assign(n, 0.0f);
  cam.bg_g2.assign(n, 0.0f);
  const double max_inc = fx_.max_incidence_deg * M_PI / 180.0;
  Ray ray;
  ray.o = cam.T_world_depth.translation();
  const Eigen::Matrix3d R = cam.T_world_depth.linear();
  for (size_t i = 0; i < n; ++i) {
    ray.d = R * cam.rays[i].cast<double>();
    SceneHit hit;
    if (!scene_.intersect(ray, snap, &static_objects_, 1e-3, 1e3, &hit)) continue;
    const float c = static_cast<float>(std::abs(hit.n_world.dot(ray.d)));
    cam.bg_z[i] = static_cast<float>(hit.t * cam.rays[i].z());
    cam.bg_cos[i] = c;
    cam.bg_refl[i] = hit.reflectivity;
    cam.bg_g2[i] = incidenceTerm(c, max_inc);
  }
  cam.depth_ready = true;
}

// Ray casts the moving objects over the cached static background, then applies the sensor
// effects (applyDepthEffects) with the frame's random streams.
void RigSimulator::renderDepth(Camera& cam, size_t index, const SceneSnapshot& snap,
                               uint64_t frame_index, DepthImage* out,
                               AmplitudeImage* amplitude) {
  ensureBackground(cam);
  const PinholeCamera& dc = cam.sensor.depth;
  const int W = static_cast<int>(dc.imageWidth()), H = static_cast<int>(dc.imageHeight());
  cam.z = cam.bg_z;
  cam.cosv = cam.bg_cos;
  cam.refl = cam.bg_refl;
  cam.g2 = cam.bg_g2;
  const double max_inc = fx_.max_incidence_deg * M_PI / 180.0;

  // Moving objects: re-cast the pixels inside their projected bounds.
  const Eigen::Isometry3d T_depth_world = cam.T_world_depth.inverse();
  const Eigen::Matrix3d R = cam.T_world_depth.linear();
  Ray ray;
  ray.o = cam.T_world_depth.translation();
  for (int obj : dynamic_objects_) {
    int u0, v0, u1, v1;
    if (!projectBounds(snap.world_bounds[obj], T_depth_world, dc, &u0, &v0, &u1, &v1)) continue;
    const std::vector<int> one{obj};
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const size_t i = static_cast<size_t>(v) * W + u;
        const Eigen::Vector3f& rc = cam.rays[i];
        const double t_max = cam.z[i] > 0 ? cam.z[i] / rc.z() : 1e3;
        ray.d = R * rc.cast<double>();
        SceneHit hit;
        if (!scene_.intersect(ray, snap, &one, 1e-3, t_max, &hit)) continue;
        const float c = static_cast<float>(std::abs(hit.n_world.dot(ray.d)));
        cam.z[i] = static_cast<float>(hit.t * rc.z());
        cam.cosv[i] = c;
        cam.refl[i] = hit.reflectivity;
        cam.g2[i] = incidenceTerm(c, max_inc);
      }
    }
  }

  DepthSceneView view;
  view.width = W;
  view.height = H;
  view.z = cam.z.data();
  view.cos_incidence = cam.cosv.data();
  view.reflectivity = cam.refl.data();
  view.g2 = cam.g2.data();
  view.ray_z = cam.ray_z.data();
  applyDepthEffects(fx_, view, cam.depth_offset, cam.depth_scale,
                    streamSeed(opt_.seed, kStreamDepthNoise, index, frame_index),
                    streamSeed(opt_.seed, kStreamInterference, index, frame_index), out,
                    amplitude);
}

// Samples per pixel of a calibration target in the colour image, on distinct sub-rows and
// sub-columns (an n-rooks pattern, row = 5 k mod 16): an edge at any angle is resolved to 1/16
// px, as a sensor integrates it (a 4 x 4 grid would snap axis-aligned edges to 1/4 px; measured
// on test_calibration's synthetic images: the corner bias of a 4 x 4 grid reached 0.1 px).
constexpr int kTargetSamples = 16;

void RigSimulator::renderColor(Camera& cam, size_t index, const SceneSnapshot& snap,
                               uint64_t frame_index, std::vector<uint8_t>* bgr) {
  const PinholeCamera& cc = cam.sensor.color;
  const int W = static_cast<int>(cc.imageWidth()), H = static_cast<int>(cc.imageHeight());
  const Eigen::Matrix3d R = cam.T_world_color.linear();
  const Eigen::Vector3d L = scene_.light.direction;
  const double amb = scene_.light.ambient;
  const Eigen::Vector3d tint = scene_.light.tint;
  auto shading = [&](const SceneHit& hit, const Eigen::Vector3d& d) {
    Eigen::Vector3d n = hit.n_world;
    if (n.dot(d) > 0) n = -n;
    return amb + (1.0 - amb) * std::max(0.0, -n.dot(L));
  };
  auto shade = [&](const SceneHit& hit, const Eigen::Vector3d& d, uint8_t* px) {
    const double k = shading(hit, d);
    for (int c = 0; c < 3; ++c)
      px[c] = static_cast<uint8_t>(std::clamp(hit.bgr[c] * k * tint[c], 0.0, 255.0));
  };
  auto rayDir = [&](double u, double v) {
    return (R * Eigen::Vector3d((u + cc.offsetX() - cc.cx()) / cc.fx(),
                                (v + cc.offsetY() - cc.cy()) / cc.fy(), 1.0))
        .normalized();
  };
  Ray ray;
  ray.o = cam.T_world_color.translation();
  // A pixel whose centre sees a calibration target: the mean of kTargetSamples rays on that
  // object; a ray missing it takes `under` (what lies behind the target's outline).
  auto supersample = [&](int u, int v, int obj, const SceneSnapshot& s, const uint8_t* under,
                         uint8_t* px) {
    const std::vector<int> one{obj};
    double acc[3] = {0.0, 0.0, 0.0};
    Ray sub = ray;
    for (int k = 0; k < kTargetSamples; ++k) {
      sub.d = rayDir(u + (k + 0.5) / kTargetSamples - 0.5,
                     v + ((5 * k) % kTargetSamples + 0.5) / kTargetSamples - 0.5);
      SceneHit h;
      const bool on = scene_.intersect(sub, s, &one, 1e-3, 1e3, &h);
      const double k_shade = on ? shading(h, sub.d) : 0.0;
      for (int c = 0; c < 3; ++c) acc[c] += on ? h.bgr[c] * k_shade * tint[c] : under[c];
    }
    for (int c = 0; c < 3; ++c)
      px[c] = static_cast<uint8_t>(std::clamp(std::lround(acc[c] / kTargetSamples), 0L, 255L));
  };
  if (!cam.color_ready) {
    const SceneSnapshot snap0 = scene_.snapshot(0.0);
    cam.bg_bgr.assign(static_cast<size_t>(W) * H * 3, 40);
    cam.bg_t.assign(static_cast<size_t>(W) * H, 1e9f);
    const uint8_t nothing[3] = {40, 40, 40};
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const size_t i = static_cast<size_t>(v) * W + u;
        ray.d = rayDir(u, v);
        SceneHit hit;
        if (!scene_.intersect(ray, snap0, &static_objects_, 1e-3, 1e3, &hit)) continue;
        cam.bg_t[i] = static_cast<float>(hit.t);
        if (scene_.objects[hit.object].texture)
          supersample(u, v, hit.object, snap0, nothing, &cam.bg_bgr[3 * i]);
        else
          shade(hit, ray.d, &cam.bg_bgr[3 * i]);
      }
    cam.color_ready = true;
  }
  cam.bgr = cam.bg_bgr;
  cam.ct = cam.bg_t;
  const Eigen::Isometry3d T_color_world = cam.T_world_color.inverse();
  for (int obj : dynamic_objects_) {
    int u0, v0, u1, v1;
    if (!projectBounds(snap.world_bounds[obj], T_color_world, cc, &u0, &v0, &u1, &v1)) continue;
    const std::vector<int> one{obj};
    const bool textured = static_cast<bool>(scene_.objects[obj].texture);
    for (int v = v0; v <= v1; ++v)
      for (int u = u0; u <= u1; ++u) {
        const size_t i = static_cast<size_t>(v) * W + u;
        ray.d = rayDir(u, v);
        SceneHit hit;
        if (!scene_.intersect(ray, snap, &one, 1e-3, std::min(1e3, double(cam.ct[i])), &hit))
          continue;
        cam.ct[i] = static_cast<float>(hit.t);
        if (textured) {
          const uint8_t under[3] = {cam.bgr[3 * i], cam.bgr[3 * i + 1], cam.bgr[3 * i + 2]};
          supersample(u, v, obj, snap, under, &cam.bgr[3 * i]);
        } else {
          shade(hit, ray.d, &cam.bgr[3 * i]);
        }
      }
  }
  bgr->resize(cam.bgr.size());
  if (!fx_.color_noise) {
    std::memcpy(bgr->data(), cam.bgr.data(), cam.bgr.size());
    return;
  }
  const std::vector<float>& normal = normalTable();
  Rng rng(streamSeed(opt_.seed, kStreamColorNoise, index, frame_index));
  const float sigma = static_cast<float>(fx_.color_noise_sigma);
  for (size_t i = 0; i < cam.bgr.size(); i += 3) {
    const uint64_t bits = rng.next();
    for (int c = 0; c < 3; ++c) {
      const float x = cam.bgr[i + c] + sigma * normal[(bits >> (16 * c)) & 0xFFFF];
      (*bgr)[i + c] = static_cast<uint8_t>(std::clamp(std::lround(x), 0L, 255L));
    }
  }
}

RigSimulator::Frame RigSimulator::render(size_t camera, double t, uint64_t frame_index) {
  Camera& cam = *cams_.at(camera);
  if (!opt_.bumps.empty()) applyBumps(cam, t);
  const SceneSnapshot snap = scene_.snapshot(t);
  Frame f;
  SensorFrameData& sf = f.sensor_frame;
  sf.camera = cam.name;
  sf.stamp_ns = stampNs(t);
  sf.frame_id = conventions::colorOpticalFrame(cam.name);
  sf.color_info = cam.color_info;
  sf.depth_info = cam.depth_info;
  sf.depth_stamp_ns = sf.stamp_ns;
  sf.depth_frame_id = conventions::depthOpticalFrame(cam.name);
  renderDepth(cam, camera, snap, frame_index, &sf.depth,
              opt_.amplitude ? &sf.amplitude : nullptr);
  if (opt_.color) {
    renderColor(cam, camera, snap, frame_index, &f.bgr);
    f.color_width = cam.sensor.color.imageWidth();
    f.color_height = cam.sensor.color.imageHeight();
  }
  if (opt_.simulated_detection)
    sf.boxes = detector_.detect(scene_, snap, cam.sensor.color, cam.T_world_color, opt_.seed,
                                camera, frame_index);
  return f;
}

std::unique_ptr<RigSimulator> loadScenario(const std::string& rig_path,
                                           const std::string& scene_path,
                                           const SimulatorOptions& opt) {
  SceneConfig scene = loadSceneConfig(scene_path);
  if (!opt.pipe_type.empty()) {
    const PipeCatalog catalog = loadPipeCatalog(sceneCatalogPath(scene_path));
    for (PipeConfig& p : scene.pipes) {
      const ToolJointDimensions& dims = catalog.at(opt.pipe_type).dims;
      // A pipe lying on a support (the catwalk) keeps lying on it: its axis moves up or down by
      // the change of the tool-joint radius, times how level the axis is (a standing joint,
      // set in the floor, keeps its pose).
      const auto rest = [&](Eigen::Isometry3d* T) {
        const double level = std::sqrt(std::max(0.0, 1.0 - std::pow(T->linear()(2, 2), 2)));
        T->translation().z() += (dims.tool_joint_od - p.dims.tool_joint_od) / 2 * level;
      };
      rest(&p.motion.T_world_anchor);
      for (Eigen::Isometry3d& T : p.motion.pose_sequence) rest(&T);
      for (Eigen::Isometry3d& T : p.motion.key_poses) rest(&T);
      p.dims = dims;
      p.pipe_type = opt.pipe_type;
    }
  }
  return std::make_unique<RigSimulator>(loadRigCalibration(rig_path), std::move(scene), opt);
}

}  // namespace drill_pipe_pose::sim
