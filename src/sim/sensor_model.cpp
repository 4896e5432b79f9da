#include "drill_pipe_pose/sim/sensor_model.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"
#include "drill_pipe_pose/sim/yaml_util.hpp"

namespace drill_pipe_pose::sim {

SensorIntrinsics SensorIntrinsics::kinectV2() {
  SensorIntrinsics s;
  s.name = "kinect_v2";
  // Kinect v2: depth 512x424 and QHD colour 960x540 (iai_kinect2 factory calibration values of
  // a typical unit).
  s.depth = PinholeCamera::fromIntrinsics(512, 424, 365.4, 365.4, 260.9, 205.6);
  s.color = PinholeCamera::fromIntrinsics(960, 540, 540.7, 540.7, 479.75, 269.75);
  s.T_color_depth = Eigen::Isometry3d::Identity();
  s.T_color_depth.translation() = Eigen::Vector3d(-0.0515, 0.0, -0.001);
  s.frame_rate_hz = 30.0;
  return s;
}

namespace {

PinholeCamera readCamera(const YAML::Node& n, const std::string& where) {
  const auto w = yamlGet<uint32_t>(n, "width", where);
  const auto h = yamlGet<uint32_t>(n, "height", where);
  const auto fx = yamlGet<double>(n, "fx", where), fy = yamlGet<double>(n, "fy", where);
  const auto cx = yamlGet<double>(n, "cx", where), cy = yamlGet<double>(n, "cy", where);
  if (w == 0 || h == 0) fail(where, ": width/height must be > 0");
  if (!(fx > 0) || !(fy > 0)) fail(where, ": fx/fy must be > 0 (got ", fx, ", ", fy, ")");
  return PinholeCamera::fromIntrinsics(w, h, fx, fy, cx, cy);
}

}  // namespace

SensorIntrinsics loadSensorIntrinsics(const std::string& path) {
  const YAML::Node root = yamlLoadFile(path);
  SensorIntrinsics s;
  s.name = yamlGet<std::string>(root, "name", path);
  s.frame_rate_hz = yamlGetOr<double>(root, "frame_rate", 30.0, path);
  if (!(s.frame_rate_hz > 0)) fail(path, ": frame_rate must be > 0");
  s.depth = readCamera(yamlChild(root, "depth", path), path + ": depth");
  s.color = readCamera(yamlChild(root, "color", path), path + ": color");
  const YAML::Node tf = yamlChild(root, "color_to_depth_tf", path);
  const std::string where = path + ": color_to_depth_tf";
  s.T_color_depth = Eigen::Isometry3d::Identity();
  s.T_color_depth.translation() = yamlVec3(tf, "translation", where);
  s.T_color_depth.linear() = yamlQuaternion(tf, "rotation", where).toRotationMatrix();
  return s;
}

SensorEffects sensorProfile(const std::string& name) {
  SensorEffects e;  // defaults = kinect_v2_calibrated
  if (name == "kinect_v2_calibrated") return e;
  if (name == "kinect_v2_field") {
    e.calibration_error = true;
    e.max_depth_offset = 0.010;  // kinect_v2_field: depth offsets up to 10 mm (docs/conventions.md)
    e.interference = true;
    return e;
  }
  if (name == "kinect_v2_uncalibrated") {
    // An uncalibrated Kinect v2: the driver's own depth calibration found +25.5 and -30.0 mm
    // for two devices; the depth scale as fitted on the first (sensor check).
    e.max_depth_offset = 0.030;
    e.depth_scale = true;
    e.brightness_bias_reference = 0.0;  // nothing calibrated away
    return e;
  }
  if (name == "ideal") {
    e.axial_noise = e.lateral_noise = e.quantisation = e.dropout = e.flying_pixels = false;
    e.amplitude_noise = e.correlated_noise = e.brightness_bias = e.saturation = false;
    e.depth_offset = e.interference = e.unsynchronised = e.calibration_error = false;
    e.wear = e.mud = e.color_noise = false;
    e.min_range = 0.0;
    e.max_range = 100.0;
    return e;
  }
  fail("sensor profile \"", name,
       "\" is unknown (expected ideal, kinect_v2_calibrated, kinect_v2_field or "
       "kinect_v2_uncalibrated)");
}

void switchOffEffect(SensorEffects* effects, const std::string& name) {
  const std::pair<const char*, bool SensorEffects::*> fields[] = {
      {"axial_noise", &SensorEffects::axial_noise},
      {"lateral_noise", &SensorEffects::lateral_noise},
      {"amplitude_noise", &SensorEffects::amplitude_noise},
      {"correlated_noise", &SensorEffects::correlated_noise},
      {"brightness_bias", &SensorEffects::brightness_bias},
      {"saturation", &SensorEffects::saturation},
      {"quantisation", &SensorEffects::quantisation},
      {"dropout", &SensorEffects::dropout},
      {"flying_pixels", &SensorEffects::flying_pixels},
      {"depth_offset", &SensorEffects::depth_offset},
      {"depth_scale", &SensorEffects::depth_scale},
      {"interference", &SensorEffects::interference},
      {"unsynchronised", &SensorEffects::unsynchronised},
      {"calibration_error", &SensorEffects::calibration_error},
      {"wear", &SensorEffects::wear},
      {"mud", &SensorEffects::mud},
      {"color_noise", &SensorEffects::color_noise},
  };
  std::string names;
  for (const auto& [n, field] : fields) {
    if (name == n) {
      effects->*field = false;
      return;
    }
    names += names.empty() ? n : std::string(", ") + n;
  }
  fail("unknown sensor effect \"", name, "\" (expected one of ", names, ")");
}

void setEffectParameter(SensorEffects* effects, const std::string& name, double value) {
  struct Field {
    const char* name;
    double SensorEffects::*field;
    double lo, hi;
  };
  const Field fields[] = {
      {"lateral_noise_px", &SensorEffects::lateral_noise_px, 0.0, 3.0},
      {"flying_probability", &SensorEffects::flying_probability, 0.0, 1.0},
      {"edge_invalid_probability", &SensorEffects::edge_invalid_probability, 0.0, 1.0},
      {"flying_weight_min", &SensorEffects::flying_weight_min, 0.0, 1.0},
      {"flying_weight_max", &SensorEffects::flying_weight_max, 0.0, 1.0},
      {"flying_jump", &SensorEffects::flying_jump, 0.0, 10.0},
      // A device whose weak-return bias differs from the fitted sensor's (calibrate_rig learns
      // it per camera); the rig file's bound.
      {"brightness_bias_coeff", &SensorEffects::brightness_bias_coeff, 0.0, 4e-8},
  };
  std::string names = "flying_amplitude_weighted";
  if (name == names) {
    if (value != 0.0 && value != 1.0)
      fail("sensor parameter ", name, " must be 0 or 1, got ", value);
    effects->flying_amplitude_weighted = value != 0.0;
    return;
  }
  for (const Field& f : fields) {
    if (name == f.name) {
      if (!(value >= f.lo && value <= f.hi))
        fail("sensor parameter ", name, " must be in [", f.lo, ", ", f.hi, "], got ", value);
      effects->*(f.field) = value;
      return;
    }
    names += std::string(", ") + f.name;
  }
  fail("unknown sensor parameter \"", name, "\" (expected one of ", names, ")");
}

void setEffectParameter(SensorEffects* effects, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    fail("sensor parameter \"", assignment, "\": expected NAME=VALUE");
  const std::string value = assignment.substr(eq + 1);
  size_t used = 0;
  double x = 0;
  try {
    x = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != value.size())
    fail("sensor parameter \"", assignment, "\": \"", value, "\" is not a number");
  setEffectParameter(effects, assignment.substr(0, eq), x);
}

void useEdgeModelBeforeRefit(SensorEffects* effects) {
  effects->lateral_noise_px = 0.8;
  effects->edge_invalid_probability = 0.0;
  effects->flying_probability = 0.35;
  effects->flying_weight_min = 0.0;
  effects->flying_weight_max = 1.0;
  effects->flying_amplitude_weighted = false;
}

void useModelBeforeFit(SensorEffects* effects) {
  effects->amplitude_noise = effects->correlated_noise = false;
  effects->brightness_bias = effects->saturation = effects->depth_scale = false;
  effects->lateral_noise_at_edges_only = false;
  effects->amplitude_by_range = false;
}

double axialNoiseSigma(double z, double theta, double max_incidence_rad) {
  const double mm =
      kinect_v2::axialSigmaMm(z, kinect_v2::incidenceFactor(std::cos(theta), max_incidence_rad));
  return std::max(mm, 0.1) * 1e-3;
}

double lateralNoiseSigmaPx(double theta, double max_incidence_rad, double head_on_px) {
  theta = std::clamp(std::abs(theta), 0.0, max_incidence_rad);
  return head_on_px + 0.035 * theta / (M_PI_2 - theta);
}

}  // namespace drill_pipe_pose::sim
