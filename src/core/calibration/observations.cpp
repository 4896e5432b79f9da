#include "drill_pipe_pose/core/calibration/observations.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose::calibration {

int ObservationSet::findCamera(const std::string& name) const {
  for (size_t i = 0; i < cameras.size(); ++i)
    if (cameras[i].name == name) return static_cast<int>(i);
  return -1;
}

namespace {

double number(const YAML::Node& n, const std::string& where) {
  if (!n || !n.IsScalar()) fail(where, " is missing or not a number");
  double x;
  try {
    x = n.as<double>();
  } catch (const YAML::Exception&) {
    fail(where, " = '", n.Scalar(), "' is not a number");
  }
  if (!std::isfinite(x)) fail(where, " = ", x, " is not finite");
  return x;
}

std::vector<double> numbers(const YAML::Node& n, size_t count, const std::string& where) {
  if (!n || !n.IsSequence() || n.size() != count)
    fail(where, " must be a list of ", count, " numbers");
  std::vector<double> v;
  for (size_t i = 0; i < count; ++i) v.push_back(number(n[i], where + "[" + std::to_string(i) + "]"));
  return v;
}

void rejectUnknown(const YAML::Node& map, const std::set<std::string>& known,
                   const std::string& where) {
  if (!map.IsMap()) fail(where, " must be a map");
  for (const auto& kv : map)
    if (!known.count(kv.first.as<std::string>())) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      fail(where, ": unknown field '", kv.first.as<std::string>(), "' (known: ", list, ")");
    }
}

Eigen::Isometry3d pose(const YAML::Node& n, const std::string& where) {
  const auto t = numbers(n["translation"], 3, where + " translation");
  const auto q = numbers(n["rotation"], 4, where + " rotation (x y z w)");
  const double qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (std::abs(qn - 1.0) > 1e-3) fail(where, " rotation has norm ", qn, ", not a unit quaternion");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(q[3] / qn, q[0] / qn, q[1] / qn, q[2] / qn).toRotationMatrix();
  T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  return T;
}

Intrinsics intrinsics(const YAML::Node& n, const std::string& where) {
  rejectUnknown(n, {"width", "height", "fx", "fy", "cx", "cy", "D"}, where);
  Intrinsics k;
  k.width = static_cast<int>(number(n["width"], where + " width"));
  k.height = static_cast<int>(number(n["height"], where + " height"));
  if (k.width <= 0 || k.height <= 0) fail(where, ": image size ", k.width, "x", k.height, " is empty");
  k.fx = number(n["fx"], where + " fx");
  k.fy = number(n["fy"], where + " fy");
  k.cx = number(n["cx"], where + " cx");
  k.cy = number(n["cy"], where + " cy");
  if (!(k.fx > 0) || !(k.fy > 0)) fail(where, ": focal lengths must be positive (fx ", k.fx, ", fy ", k.fy, ")");
  if (n["D"]) k.D = numbers(n["D"], 5, where + " D (k1 k2 p1 p2 k3)");
  return k;
}

TargetGeometry target(const YAML::Node& n, const std::string& where) {
  rejectUnknown(n, {"type", "squares_x", "squares_y", "square_length", "marker_length", "dictionary"},
                where);
  TargetGeometry t;
  if (!n["type"]) fail(where, ": field 'type' is missing (charuco | chessboard)");
  const std::string type = n["type"].as<std::string>();
  if (type == "charuco")
    t.type = TargetGeometry::Type::kCharuco;
  else if (type == "chessboard")
    t.type = TargetGeometry::Type::kChessboard;
  else
    fail(where, " type = '", type, "' (expected charuco or chessboard)");
  // (Range-checked before the conversion to int.)
  auto squares = [&](const char* key) {
    const double s = number(n[key], where + " " + key);
    if (std::abs(s) > kMaxTargetSquares)
      fail(where, " ", key, " = ", s, ": at most ", kMaxTargetSquares, " squares per side");
    return static_cast<int>(s);
  };
  t.squares_x = squares("squares_x");
  t.squares_y = squares("squares_y");
  t.square_length = number(n["square_length"], where + " square_length [m]");
  if (t.type == TargetGeometry::Type::kCharuco) {
    t.marker_length = number(n["marker_length"], where + " marker_length [m]");
    if (n["dictionary"]) t.dictionary = n["dictionary"].as<std::string>();
  }
  validateTarget(t, where);
  return t;
}

Observation observation(const YAML::Node& n, const ObservationSet& set, size_t index,
                        const std::string& source) {
  const std::string where = source + ": observations[" + std::to_string(index) + "]";
  rejectUnknown(n, {"camera", "placement", "stamp", "corners", "depth", "amplitude"}, where);
  Observation o;
  if (!n["camera"]) fail(where, ": field 'camera' is missing");
  o.camera = n["camera"].as<std::string>();
  const int cam = set.findCamera(o.camera);
  if (cam < 0) fail(where, ": camera '", o.camera, "' is not in 'cameras'");
  const Intrinsics& k = set.cameras[cam].intrinsics;
  o.placement = static_cast<int>(number(n["placement"], where + " placement"));
  if (o.placement < 0) fail(where, ": placement ", o.placement, " is negative");
  if (n["stamp"]) o.stamp = number(n["stamp"], where + " stamp");
  const YAML::Node corners = n["corners"];
  if (corners && !corners.IsSequence()) fail(where, " corners must be a list of [id, u, v]");
  for (size_t i = 0; corners && i < corners.size(); ++i) {
    const auto c = numbers(corners[i], 3, where + " corners[" + std::to_string(i) + "] [id, u, v]");
    if (c[1] < -0.5 || c[2] < -0.5 || c[1] > k.width - 0.5 || c[2] > k.height - 0.5)
      fail(where, " (camera ", o.camera, "): corner ", c[0], " at (", c[1], ", ", c[2],
           ") px lies outside the camera's ", k.width, "x", k.height,
           " image: are the intrinsics those of the images the corners were found in?");
    o.corners.push_back({static_cast<int>(c[0]), Eigen::Vector2d(c[1], c[2])});
  }
  const YAML::Node depth = n["depth"];
  if (depth && !set.cameras[cam].depth_intrinsics)
    fail(where, ": camera '", o.camera, "' has depth samples but no depth_intrinsics");
  for (size_t i = 0; depth && i < depth.size(); ++i) {
    const std::string at = where + " depth[" + std::to_string(i) + "] [u, v, z(, sigma(, a))]";
    const size_t n = depth[i].IsSequence() && (depth[i].size() == 4 || depth[i].size() == 5)
                         ? depth[i].size()
                         : 3;
    const auto d = numbers(depth[i], n, at);
    if (!(d[2] > 0)) fail(at, ": z = ", d[2], " m must be positive");
    if (d.size() >= 4 && !(d[3] >= 0)) fail(at, ": sigma = ", d[3], " m must not be negative");
    if (d.size() == 5 && !(d[4] >= 0)) fail(at, ": a = ", d[4], " 1/m^2 must not be negative");
    o.depth.push_back({d[0], d[1], d[2], d.size() >= 4 ? d[3] : 0.0, d.size() == 5 ? d[4] : 0.0});
  }
  const YAML::Node amplitude = n["amplitude"];
  if (amplitude && !set.cameras[cam].depth_intrinsics)
    fail(where, ": camera '", o.camera, "' has amplitude samples but no depth_intrinsics");
  if (amplitude && !amplitude.IsSequence())
    fail(where, " amplitude must be a list of [u, v, z, a]");
  for (size_t i = 0; amplitude && i < amplitude.size(); ++i) {
    const std::string at = where + " amplitude[" + std::to_string(i) + "] [u, v, z, a]";
    const auto d = numbers(amplitude[i], 4, at);
    if (!(d[2] > 0)) fail(at, ": z = ", d[2], " m must be positive");
    if (!(d[3] > 0)) fail(at, ": a = ", d[3], " 1/m^2 must be positive");
    o.amplitude.push_back({d[0], d[1], d[2], d[3]});
  }
  return o;
}

/// The anchor (placement or camera at a known world pose) into set->anchor; the camera's
/// presence is the caller's to check.
void readAnchor(const YAML::Node& anchor, const std::string& source, ObservationSet* set) {
  if (!anchor) fail(source, ": field 'anchor' is missing (placement or camera at a known world pose)");
  rejectUnknown(anchor, {"placement", "camera", "translation", "rotation"}, source + ": anchor");
  if (anchor["placement"].IsDefined() == anchor["camera"].IsDefined())
    fail(source, ": anchor needs exactly one of 'placement' and 'camera'");
  if (anchor["placement"])
    set->anchor.placement = static_cast<int>(number(anchor["placement"], source + ": anchor placement"));
  else
    set->anchor.camera = anchor["camera"].as<std::string>();
  set->anchor.T_world_anchor = pose(anchor, source + ": anchor");
}

YAML::Node loadYaml(const std::string& text, const std::string& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(source, ": not valid YAML: ", e.what());
  }
}

}  // namespace

Intrinsics intrinsicsFromCameraInfo(const CameraInfoData& m, const std::string& where) {
  Intrinsics k;
  k.width = static_cast<int>(m.width);
  k.height = static_cast<int>(m.height);
  k.fx = m.K[0];
  k.fy = m.K[4];
  k.cx = m.K[2];
  k.cy = m.K[5];
  if (!(k.fx > 0) || !(k.fy > 0) || k.width <= 0 || k.height <= 0)
    fail(where, ": camera_info has no usable K or size (fx ", k.fx, ", fy ", k.fy, ", ", k.width,
         "x", k.height, ")");
  for (size_t i = 0; i < m.D.size(); ++i) {
    if (i < 5)
      k.D[i] = m.D[i];
    else if (m.D[i] != 0.0)
      fail(where, ": distortion model '", m.distortion_model, "' with ", m.D.size(),
           " coefficients; only plumb_bob (5) is supported");
  }
  return k;
}

ObservationSet parseObservations(const std::string& text, const std::string& source) {
  const YAML::Node root = loadYaml(text, source);
  rejectUnknown(root, {"world_frame", "target", "anchor", "cameras", "observations"}, source);
  ObservationSet set;
  if (root["world_frame"]) set.world_frame = root["world_frame"].as<std::string>();
  if (!root["target"]) fail(source, ": field 'target' is missing");
  set.target = target(root["target"], source + ": target");
  const YAML::Node cams = root["cameras"];
  if (!cams || !cams.IsSequence() || cams.size() == 0)
    fail(source, ": 'cameras' must be a non-empty list");
  for (size_t i = 0; i < cams.size(); ++i) {
    const YAML::Node c = cams[i];
    std::string where = source + ": cameras[" + std::to_string(i) + "]";
    rejectUnknown(c, {"name", "sensor", "intrinsics", "depth_intrinsics", "T_camera_depth"}, where);
    CameraSetup cam;
    if (!c["name"]) fail(where, ": field 'name' is missing");
    cam.name = c["name"].as<std::string>();
    where = source + ": camera '" + cam.name + "'";
    if (set.findCamera(cam.name) >= 0) fail(where, ": duplicate camera name");
    if (c["sensor"]) cam.sensor = c["sensor"].as<std::string>();
    if (!c["intrinsics"]) fail(where, ": field 'intrinsics' is missing");
    cam.intrinsics = intrinsics(c["intrinsics"], where + " intrinsics");
    if (c["depth_intrinsics"])
      cam.depth_intrinsics = intrinsics(c["depth_intrinsics"], where + " depth_intrinsics");
    if (c["T_camera_depth"]) cam.T_camera_depth = pose(c["T_camera_depth"], where + " T_camera_depth");
    set.cameras.push_back(cam);
  }
  readAnchor(root["anchor"], source, &set);
  if (set.anchor.camera && set.findCamera(*set.anchor.camera) < 0)
    fail(source, ": anchor camera '", *set.anchor.camera, "' is not in 'cameras'");
  const YAML::Node obs = root["observations"];
  if (obs && !obs.IsSequence()) fail(source, ": 'observations' must be a list");
  for (size_t i = 0; obs && i < obs.size(); ++i)
    set.observations.push_back(observation(obs[i], set, i, source));
  return set;
}

ObservationSet parseCalibrationConfig(const std::string& text, const std::string& source) {
  const YAML::Node root = loadYaml(text, source);
  rejectUnknown(root, {"world_frame", "target", "anchor"}, source);
  ObservationSet set;
  if (root["world_frame"]) set.world_frame = root["world_frame"].as<std::string>();
  if (!root["target"]) fail(source, ": field 'target' is missing");
  set.target = target(root["target"], source + ": target");
  readAnchor(root["anchor"], source, &set);
  return set;
}

ObservationSet loadCalibrationConfig(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail("calibration config '", path, "' cannot be read");
  std::stringstream ss;
  ss << f.rdbuf();
  return parseCalibrationConfig(ss.str(), path);
}

ObservationSet loadObservations(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail("observations file '", path, "' cannot be read");
  std::stringstream ss;
  ss << f.rdbuf();
  return parseObservations(ss.str(), path);
}

namespace {

void writePose(std::ostream& s, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  s << "translation: [" << t.x() << ", " << t.y() << ", " << t.z() << "], rotation: [" << q.x()
    << ", " << q.y() << ", " << q.z() << ", " << q.w() << "]";
}

void writeIntrinsics(std::ostream& s, const Intrinsics& k) {
  s << "{width: " << k.width << ", height: " << k.height << ", fx: " << k.fx << ", fy: " << k.fy
    << ", cx: " << k.cx << ", cy: " << k.cy << ", D: [";
  for (size_t i = 0; i < k.D.size(); ++i) s << (i ? ", " : "") << k.D[i];
  s << "]}";
}

}  // namespace

std::string observationsToYaml(const ObservationSet& set) {
  std::ostringstream s;
  s.precision(12);
  const TargetGeometry& t = set.target;
  s << "world_frame: " << set.world_frame << "\ntarget: {type: "
    << (t.type == TargetGeometry::Type::kCharuco ? "charuco" : "chessboard")
    << ", squares_x: " << t.squares_x << ", squares_y: " << t.squares_y
    << ", square_length: " << t.square_length;
  if (t.type == TargetGeometry::Type::kCharuco)
    s << ", marker_length: " << t.marker_length << ", dictionary: " << t.dictionary;
  s << "}\nanchor: {";
  if (set.anchor.placement)
    s << "placement: " << *set.anchor.placement << ", ";
  else
    s << "camera: " << set.anchor.camera.value_or("") << ", ";
  writePose(s, set.anchor.T_world_anchor);
  s << "}\ncameras:\n";
  for (const CameraSetup& c : set.cameras) {
    s << "  - name: " << c.name << "\n    sensor: " << c.sensor << "\n    intrinsics: ";
    writeIntrinsics(s, c.intrinsics);
    if (c.depth_intrinsics) {
      s << "\n    depth_intrinsics: ";
      writeIntrinsics(s, *c.depth_intrinsics);
    }
    s << "\n    T_camera_depth: {";
    writePose(s, c.T_camera_depth);
    s << "}\n";
  }
  s << "observations:\n";
  for (const Observation& o : set.observations) {
    s << "  - camera: " << o.camera << "\n    placement: " << o.placement
      << "\n    stamp: " << o.stamp << "\n    corners: [";
    s << std::fixed << std::setprecision(3);
    for (size_t i = 0; i < o.corners.size(); ++i)
      s << (i ? ", " : "") << "[" << o.corners[i].id << ", " << o.corners[i].uv.x() << ", "
        << o.corners[i].uv.y() << "]";
    s << "]\n";
    if (!o.depth.empty()) {
      s << "    depth: [";
      for (size_t i = 0; i < o.depth.size(); ++i)
      {
        s << (i ? ", " : "") << "[" << std::setprecision(1) << o.depth[i].u << ", "
          << o.depth[i].v << ", " << std::setprecision(5) << o.depth[i].z;
        if (o.depth[i].sigma > 0 || o.depth[i].amplitude > 0) s << ", " << o.depth[i].sigma;
        if (o.depth[i].amplitude > 0) s << ", " << std::setprecision(6) << o.depth[i].amplitude;
        s << "]";
      }
      s << "]\n";
    }
    if (!o.amplitude.empty()) {
      s << "    amplitude: [";
      for (size_t i = 0; i < o.amplitude.size(); ++i) {
        const AmplitudeSample& a = o.amplitude[i];
        s << (i ? ", " : "") << "[" << std::setprecision(1) << a.u << ", " << a.v << ", "
          << std::setprecision(5) << a.z << ", " << std::setprecision(6) << a.amplitude << "]";
      }
      s << "]\n";
    }
    s << std::defaultfloat << std::setprecision(12);
  }
  return s.str();
}

void saveObservations(const ObservationSet& set, const std::string& path) {
  std::ofstream f(path);
  if (!f) fail("observations file '", path, "' cannot be written");
  f << observationsToYaml(set);
  if (!f) fail("observations file '", path, "': write failed");
}

}  // namespace drill_pipe_pose::calibration
