#include "drill_pipe_pose/sim/rig_simulator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "drill_pipe_pose/sim/random.hpp"

namespace drill_pipe_pose::sim {

namespace {

/// Inverse standard-normal CDF (Acklam's rational approximation, |rel. error| < 1.2e-9).
double inverseNormalCdf(double p) {
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01, -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  const double pl = 0.02425;
  if (p < pl) {
    const double q = std::sqrt(-2 * std::log(p));
    return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  }
  if (p > 1 - pl) {
    const double q = std::sqrt(-2 * std::log(1 - p));
    return -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  }
  const double q = p - 0.5, r = q * q;
  return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
         (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
}

/// Standard normal by table lookup of 16 random bits: the inverse CDF at the 65536 bin centres
/// (exact mean 0, variance within 0.1 % of 1, tails to +-4.3 sigma). Fast enough to draw one
/// per depth pixel.
const std::vector<float>& normalTable() {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    double sum2 = 0;
    for (int i = 0; i < 65536; ++i) {
      t[i] = static_cast<float>(inverseNormalCdf((i + 0.5) / 65536.0));
      sum2 += static_cast<double>(t[i]) * t[i];
    }
    const float scale = static_cast<float>(1.0 / std::sqrt(sum2 / 65536.0));  // exact variance
    for (float& v : t) v *= scale;
    return t;
  }();
  return table;
}

/// Lateral pixel shift tables: for sigma = 0.8 + 0.1 k px, 256 entries of round(N(0, sigma)),
/// clamped to +-3 px.
constexpr int kLateralTables = 30;
const std::vector<std::array<int8_t, 256>>& lateralTables() {
  static const std::vector<std::array<int8_t, 256>> tables = [] {
    std::vector<std::array<int8_t, 256>> t(kLateralTables);
    for (int k = 0; k < kLateralTables; ++k) {
      const double sigma = 0.8 + 0.1 * k;
      for (int i = 0; i < 256; ++i) {
        const double x = sigma * inverseNormalCdf((i + 0.5) / 256.0);
        t[k][i] = static_cast<int8_t>(std::clamp<long>(std::lround(x), -3, 3));
      }
    }
    return t;
  }();
  return tables;
}

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

/// The incidence term g^2 = (theta / (pi/2 - theta))^2 of Fankhauser's model from cos(theta).
float incidenceTerm(float cos_theta, double max_incidence_rad) {
  return static_cast<float>(
      kinect_v2::incidenceFactor(static_cast<double>(cos_theta), max_incidence_rad));
}

}  // namespace

/// Per-camera state: geometry, seeded setup, cached static background and work buffers.
struct RigSimulator::Camera {
  std::string name;
  SensorIntrinsics sensor;
  Eigen::Isometry3d T_world_link_true, T_world_link_pub, T_world_depth, T_world_color;
  CameraInfoData color_info, depth_info;
  double depth_offset = 0.0;          ///< [m]
  double phase = 0.0;                 ///< [s]
  std::vector<Eigen::Vector3f> rays;  ///< unit ray of each depth pixel, depth optical frame
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
    cams_.push_back(std::move(cam));
  }
}

RigSimulator::~RigSimulator() = default;

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
      out.push_back(
          {scene_.ends[i].label, scene_.ends[i].pipe, canonicalize(scene_.endPose(i, t))});
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

// Over 120 lines because the sensor effects run in one pass per pixel, drawing their random
// numbers in a fixed order (the rendered frames of a seed must not change).
void RigSimulator::renderDepth(Camera& cam, size_t index, const SceneSnapshot& snap,
                               uint64_t frame_index, DepthImage* out) {
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

  const DepthEncoding enc =
      fx_.quantisation ? DepthEncoding::kU16Millimetres : DepthEncoding::kF32Metres;
  *out = DepthImage::allocate(W, H, enc);
  const std::vector<float>& normal = normalTable();
  const auto& lateral = lateralTables();
  Rng rng(streamSeed(opt_.seed, kStreamDepthNoise, index, frame_index));

  // Interference burst of this frame (drawn always, applied when enabled).
  Rng irng(streamSeed(opt_.seed, kStreamInterference, index, frame_index));
  const bool burst = irng.chance(fx_.interference_probability) && fx_.interference;
  const int band_h = static_cast<int>(fx_.interference_band_fraction * H);
  const int band_v0 = static_cast<int>(irng.uniform(0.0, std::max(1, H - band_h)));

  const float zmin = static_cast<float>(fx_.min_range), zmax = static_cast<float>(fx_.max_range);
  const float a_lo = static_cast<float>(fx_.dropout_amplitude_low);
  const float a_hi = static_cast<float>(fx_.dropout_amplitude_high);
  const float inv_ramp = 1.0f / std::max(a_hi - a_lo, 1e-9f);
  const float flying_p = static_cast<float>(fx_.flying_probability);
  const float jump = static_cast<float>(fx_.flying_jump);
  const float offset = static_cast<float>(cam.depth_offset);
  const float axial_scale = static_cast<float>(fx_.axial_noise_scale);
  const bool lateral_on = fx_.lateral_noise, flying_on = fx_.flying_pixels;
  const bool dropout_on = fx_.dropout, axial_on = fx_.axial_noise;
  const bool noisy = lateral_on || flying_on || dropout_on || axial_on || burst;
  const float* Z = cam.z.data();

  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      if (!noisy) {
        const float z = Z[i];
        if (z > 0 && z >= zmin && z <= zmax) out->setDepth(u, v, z + offset);
        continue;
      }
      const uint64_t bits = rng.next();
      size_t s = i;
      int su = u, sv = v;
      if (lateral_on) {
        const float g = std::sqrt(cam.g2[i]);
        const float sigma_px = 0.8f + 0.035f * g;  // Fankhauser et al. 2015, lateral
        const int k = std::min(kLateralTables - 1, static_cast<int>((sigma_px - 0.8f) * 10.0f));
        su = std::clamp(u + lateral[k][bits & 0xFF], 0, W - 1);
        sv = std::clamp(v + lateral[k][(bits >> 8) & 0xFF], 0, H - 1);
        s = static_cast<size_t>(sv) * W + su;
      }
      float z = Z[s];
      if (!(z > 0)) continue;
      if (flying_on) {
        // Largest depth jump to a 4-neighbour of the source pixel.
        float znb = z, best = 0.0f;
        const int nu[4] = {su - 1, su + 1, su, su};
        const int nv[4] = {sv, sv, sv - 1, sv + 1};
        for (int q = 0; q < 4; ++q) {
          if (nu[q] < 0 || nu[q] >= W || nv[q] < 0 || nv[q] >= H) continue;
          const float zn = Z[static_cast<size_t>(nv[q]) * W + nu[q]];
          if (zn > 0 && std::abs(zn - z) > best) {
            best = std::abs(zn - z);
            znb = zn;
          }
        }
        if (best > jump && ((bits >> 16) & 0xFFFF) * (1.0f / 65536.0f) < flying_p) {
          const float w = ((bits >> 48) & 0xFFFF) * (1.0f / 65536.0f);
          z += w * (znb - z);
        }
      }
      if (z < zmin || z > zmax) continue;
      if (dropout_on) {
        const float a = cam.refl[s] * cam.cosv[s] / (z * z);
        const float p_drop = (a_hi - a) * inv_ramp;
        if (p_drop > 0 && ((bits >> 32) & 0xFFFF) * (1.0f / 65536.0f) < p_drop) continue;
      }
      if (axial_on) {
        const float sigma_mm = std::max(0.1f, kinect_v2::axialSigmaMm(z, cam.g2[s]));
        const uint64_t nb = rng.next();
        z += axial_scale * sigma_mm * 1e-3f * normal[nb & 0xFFFF];
        if (burst && v >= band_v0 && v < band_v0 + band_h) {
          z += static_cast<float>(fx_.interference_sigma) * normal[(nb >> 16) & 0xFFFF];
          if (((nb >> 32) & 0xFFFF) * (1.0f / 65536.0f) < fx_.interference_dropout) continue;
        }
      } else if (burst && v >= band_v0 && v < band_v0 + band_h) {
        const uint64_t nb = rng.next();
        z += static_cast<float>(fx_.interference_sigma) * normal[(nb >> 16) & 0xFFFF];
        if (((nb >> 32) & 0xFFFF) * (1.0f / 65536.0f) < fx_.interference_dropout) continue;
      }
      z += offset;
      if (z > 0) out->setDepth(u, v, z);
    }
  }
}

void RigSimulator::renderColor(Camera& cam, size_t index, const SceneSnapshot& snap,
                               uint64_t frame_index, std::vector<uint8_t>* bgr) {
  const PinholeCamera& cc = cam.sensor.color;
  const int W = static_cast<int>(cc.imageWidth()), H = static_cast<int>(cc.imageHeight());
  const Eigen::Matrix3d R = cam.T_world_color.linear();
  const Eigen::Vector3d L = scene_.light.direction;
  const double amb = scene_.light.ambient;
  auto shade = [&](const SceneHit& hit, const Eigen::Vector3d& d, uint8_t* px) {
    Eigen::Vector3d n = hit.n_world;
    if (n.dot(d) > 0) n = -n;
    const double k = amb + (1.0 - amb) * std::max(0.0, -n.dot(L));
    for (int c = 0; c < 3; ++c)
      px[c] = static_cast<uint8_t>(std::clamp(hit.bgr[c] * k, 0.0, 255.0));
  };
  auto rayDir = [&](int u, int v) {
    return (R * Eigen::Vector3d((u + cc.offsetX() - cc.cx()) / cc.fx(),
                                (v + cc.offsetY() - cc.cy()) / cc.fy(), 1.0))
        .normalized();
  };
  Ray ray;
  ray.o = cam.T_world_color.translation();
  if (!cam.color_ready) {
    const SceneSnapshot snap0 = scene_.snapshot(0.0);
    cam.bg_bgr.assign(static_cast<size_t>(W) * H * 3, 40);
    cam.bg_t.assign(static_cast<size_t>(W) * H, 1e9f);
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const size_t i = static_cast<size_t>(v) * W + u;
        ray.d = rayDir(u, v);
        SceneHit hit;
        if (!scene_.intersect(ray, snap0, &static_objects_, 1e-3, 1e3, &hit)) continue;
        cam.bg_t[i] = static_cast<float>(hit.t);
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
    for (int v = v0; v <= v1; ++v)
      for (int u = u0; u <= u1; ++u) {
        const size_t i = static_cast<size_t>(v) * W + u;
        ray.d = rayDir(u, v);
        SceneHit hit;
        if (!scene_.intersect(ray, snap, &one, 1e-3, std::min(1e3, double(cam.ct[i])), &hit))
          continue;
        cam.ct[i] = static_cast<float>(hit.t);
        shade(hit, ray.d, &cam.bgr[3 * i]);
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
  renderDepth(cam, camera, snap, frame_index, &sf.depth);
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
  return std::make_unique<RigSimulator>(loadRigCalibration(rig_path), loadSceneConfig(scene_path),
                                        opt);
}

}  // namespace drill_pipe_pose::sim
