#include "drill_pipe_pose/core/rig_calibration.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

int RigCalibration::find(const std::string& name) const {
  for (size_t i = 0; i < cameras.size(); ++i)
    if (cameras[i].name == name) return static_cast<int>(i);
  return -1;
}

namespace {

std::vector<double> numbers(const YAML::Node& node, size_t n, const std::string& where) {
  if (!node) fail(where, " is missing (", n, " numbers expected)");
  if (!node.IsSequence() || node.size() != n)
    fail(where, " must be a list of ", n, " numbers, got ",
         node.IsSequence() ? std::to_string(node.size()) + " elements" : "a non-list");
  std::vector<double> v;
  for (size_t i = 0; i < n; ++i) {
    double x;
    try {
      x = node[i].as<double>();
    } catch (const YAML::Exception&) {
      fail(where, "[", i, "] = '", node[i].Scalar(), "' is not a number");
    }
    if (!std::isfinite(x)) fail(where, "[", i, "] = ", x, " is not finite");
    v.push_back(x);
  }
  return v;
}

void rejectUnknownKeys(const YAML::Node& map, const std::set<std::string>& known,
                       const std::string& where) {
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>();
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      fail(where, ": unknown field '", key, "' (known: ", list, ")");
    }
  }
}

/// An optional number: `fallback` when absent; finite and within [lo, hi] otherwise.
double optionalNumber(const YAML::Node& node, double fallback, double lo, double hi,
                      const std::string& where) {
  if (!node) return fallback;
  double x;
  try {
    x = node.as<double>();
  } catch (const YAML::Exception&) {
    fail(where, " = '", node.IsScalar() ? node.Scalar() : std::string("(not a number)"),
         "' is not a number");
  }
  if (!std::isfinite(x)) fail(where, " = ", x, " is not finite");
  if (x < lo || x > hi) fail(where, " = ", x, " is outside [", lo, ", ", hi, "]");
  return x;
}

/// A string field: InputError naming it when it is a list, a map or null.
std::string scalarText(const YAML::Node& node, const std::string& where) {
  if (!node.IsScalar()) fail(where, " must be a string");
  return node.Scalar();
}

/// A TF frame or sensor model name: printable ASCII, no spaces (a control character or a byte
/// of broken UTF-8 in a frame id is a corrupt file, and TF would carry it on).
std::string frameName(const YAML::Node& node, const std::string& where) {
  static const std::regex re("[A-Za-z0-9_][A-Za-z0-9_./-]*");
  const std::string s = scalarText(node, where);
  if (!std::regex_match(s, re))
    fail(where, " = '", s, "' must match [A-Za-z0-9_][A-Za-z0-9_./-]*");
  return s;
}

/// `s` as a YAML scalar that reads back as `s` (plain where it can be, else quoted and escaped:
/// a world frame or sensor name with ': ', '#' or a control character in it).
std::string yamlScalar(const std::string& s) {
  YAML::Emitter e;
  e << s;
  return std::string(e.c_str(), e.size());
}

}  // namespace

namespace {

/// The rig file's content (parseRigCalibration): validated, every error naming the field.
RigCalibration parseRoot(const YAML::Node& root, const std::string& source) {
  if (!root.IsMap()) fail(source, ": expected a map with 'cameras'");
  rejectUnknownKeys(root, {"world_frame", "cameras"}, source);
  RigCalibration rig;
  if (root["world_frame"])
    rig.world_frame = frameName(root["world_frame"], source + ": world_frame");
  const YAML::Node cams = root["cameras"];
  if (!cams || !cams.IsSequence() || cams.size() == 0)
    fail(source, ": 'cameras' must be a non-empty list");
  static const std::regex name_re("[A-Za-z][A-Za-z0-9_]*");
  for (size_t i = 0; i < cams.size(); ++i) {
    const YAML::Node c = cams[i];
    const std::string at = source + ": cameras[" + std::to_string(i) + "]";
    if (!c.IsMap()) fail(at, " must be a map with name, translation, rotation");
    if (!c["name"]) fail(at, ": field 'name' is missing");
    CameraCalibration cal;
    cal.name = scalarText(c["name"], at + ": name");
    const std::string where = source + ": camera '" + cal.name + "'";
    if (!std::regex_match(cal.name, name_re))
      fail(where, ": name must match [A-Za-z][A-Za-z0-9_]* (it prefixes topics and frames)");
    if (rig.find(cal.name) >= 0) fail(where, ": duplicate camera name");
    rejectUnknownKeys(
        c, {"name", "translation", "rotation", "sensor", "depth_offset", "depth_scale",
            "weak_return_bias"},
        where);
    const auto t = numbers(c["translation"], 3, where + " translation");
    const auto q = numbers(c["rotation"], 4, where + " rotation (x y z w)");
    const double qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (std::abs(qn - 1.0) > 1e-3)
      fail(where, ": rotation (x y z w) has norm ", qn, ", a unit quaternion is required");
    const Eigen::Quaterniond quat(q[3] / qn, q[0] / qn, q[1] / qn, q[2] / qn);
    cal.T_world_link.linear() = quat.toRotationMatrix();
    cal.T_world_link.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    if (c["sensor"]) cal.sensor = frameName(c["sensor"], where + " sensor");
    cal.depth_offset = optionalNumber(c["depth_offset"], 0.0, -kMaxDepthOffset, kMaxDepthOffset,
                                      where + " depth_offset [m]");
    cal.depth_scale = optionalNumber(c["depth_scale"], 1.0, kMinDepthScale, kMaxDepthScale,
                                     where + " depth_scale");
    if (c["weak_return_bias"])
      cal.weak_return_bias =
          optionalNumber(c["weak_return_bias"], 0.0, 0.0, kMaxWeakReturnBias,
                         where + " weak_return_bias [m (1/m^2)^4]");
    rig.cameras.push_back(cal);
  }
  return rig;
}

}  // namespace

RigCalibration parseRigCalibration(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(source, ": not valid YAML: ", e.what());
  }
  try {
    return parseRoot(root, source);
  } catch (const YAML::Exception& e) {  // a node of an unexpected kind (a list as a key, ...)
    fail(source, ": ", e.what());
  }
}

RigCalibration loadRigCalibration(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail("rig calibration file '", path, "' cannot be read");
  std::stringstream ss;
  ss << f.rdbuf();
  return parseRigCalibration(ss.str(), path);
}

std::string rigCalibrationToYaml(const RigCalibration& rig) {
  std::ostringstream s;
  s.precision(17);
  s << "world_frame: " << yamlScalar(rig.world_frame) << "\ncameras:\n";
  for (const auto& c : rig.cameras) {
    const Eigen::Quaterniond q(c.T_world_link.linear());
    const Eigen::Vector3d t = c.T_world_link.translation();
    s << "  - name: " << c.name << "\n    sensor: " << yamlScalar(c.sensor)
      << "\n    translation: [" << t.x() << ", " << t.y() << ", " << t.z() << "]\n    rotation: ["
      << q.x() << ", " << q.y() << ", " << q.z() << ", " << q.w() << "]\n";
    // The depth calibration only where there is one: a plain rig file stays as it was.
    if (c.depth_offset != 0.0) s << "    depth_offset: " << c.depth_offset << "\n";
    if (c.depth_scale != 1.0) s << "    depth_scale: " << c.depth_scale << "\n";
    if (c.weak_return_bias) s << "    weak_return_bias: " << *c.weak_return_bias << "\n";
  }
  return s.str();
}

}  // namespace drill_pipe_pose
