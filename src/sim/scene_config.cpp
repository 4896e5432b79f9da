#include "drill_pipe_pose/sim/scene_config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "drill_pipe_pose/sim/random.hpp"
#include "drill_pipe_pose/sim/yaml_util.hpp"

namespace drill_pipe_pose::sim {

std::map<std::string, Material> builtinMaterials() {
  // Reflectivities are relative diffuse IR (850 nm) reflectivities, assumed from typical
  // surfaces (paint ~0.5-0.7, concrete ~0.4, bare/dark steel < 0.1); colours are BGR.
  std::map<std::string, Material> m;
  auto add = [&](const char* name, double refl, uint8_t b, uint8_t g, uint8_t r) {
    m[name] = Material{name, refl, {{b, g, r}}};
  };
  add("concrete", 0.45, 150, 152, 155);
  add("wall_paint", 0.70, 205, 208, 210);
  add("yellow_paint", 0.60, 20, 195, 230);  // the thesis's yellow-painted pipes
  add("grey_paint", 0.50, 120, 120, 125);
  add("dark_steel", 0.12, 60, 62, 66);  // unpainted, oily tool-joint steel
  add("rusty_steel", 0.15, 40, 70, 115);
  add("barrel_blue", 0.45, 150, 80, 30);
  add("cardboard", 0.50, 90, 140, 185);
  add("hi_vis", 0.55, 20, 120, 250);  // person in orange overalls
  add("catwalk_steel", 0.30, 95, 95, 100);
  add("black_rubber", 0.05, 30, 30, 30);
  return m;
}

namespace {

std::string at(const std::string& where, const std::string& key) {
  return where + "." + key;
}

Eigen::Isometry3d parsePose(const YAML::Node& map, const std::string& where) {
  if (!map.IsMap()) fail(where, ": expected a map {translation, rpy_deg|quaternion|z_axis}");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d t = yamlVec3(map, "translation", where);
  int n_rot = (map["rpy_deg"] ? 1 : 0) + (map["quaternion"] ? 1 : 0) + (map["z_axis"] ? 1 : 0);
  if (n_rot > 1) fail(where, ": give only one of rpy_deg, quaternion, z_axis");
  if (map["rpy_deg"]) {
    const Eigen::Vector3d rpy = yamlVec3(map, "rpy_deg", where) * M_PI / 180.0;
    T.linear() = (Eigen::AngleAxisd(rpy[2], Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(rpy[1], Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(rpy[0], Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
  } else if (map["quaternion"]) {
    T.linear() = yamlQuaternion(map, "quaternion", where).toRotationMatrix();
  } else if (map["z_axis"]) {
    const Eigen::Vector3d z = yamlVec3(map, "z_axis", where);
    if (z.norm() < 1e-9) fail(where, ": z_axis: expected a non-zero vector");
    T.linear() = canonicalRotation(z.normalized());
  }
  T.translation() = t;
  return T;
}

Material parseMaterial(const YAML::Node& n, const std::string& name, const std::string& where) {
  Material m;
  m.name = name;
  m.reflectivity = yamlGet<double>(n, "reflectivity", where);
  if (m.reflectivity < 0.0 || m.reflectivity > 1.0)
    fail(where, ": reflectivity: expected a number in [0, 1], got ", m.reflectivity);
  const Eigen::Vector3d c = yamlVec3(n, "bgr", where);
  for (int i = 0; i < 3; ++i) {
    if (c[i] < 0 || c[i] > 255) fail(where, ": bgr: expected 3 numbers in [0, 255]");
    m.bgr[i] = static_cast<uint8_t>(std::lround(c[i]));
  }
  return m;
}

const std::string& checkMaterial(const std::map<std::string, Material>& mats,
                                 const std::string& name, const std::string& where) {
  if (!mats.count(name)) {
    std::string known;
    for (const auto& kv : mats) known += (known.empty() ? "" : ", ") + kv.first;
    fail(where, ": material: unknown material \"", name, "\" (known: ", known, ")");
  }
  return name;
}

struct RandomPoseSpec {
  int count = 60;
  double interval_s = 2.0;
  uint64_t seed = 7;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d half_extent = Eigen::Vector2d(1.0, 1.0);
  Eigen::Vector2d tilt_deg = Eigen::Vector2d(0.0, 90.0);
  double hanging_fraction = 0.3;
  // Share of the poses standing upright (tilt 0-5 deg) in the floor, as a stump stands in the
  // slips or a joint in the mousehole: the end's origin standing_height above the floor (the rest
  // of the pipe below it; at most the height at which it rests on the floor). Drawn after
  // hanging_fraction; 0 draws nothing, so a scene without it keeps its poses.
  double standing_fraction = 0.0;
  Eigen::Vector2d standing_height = Eigen::Vector2d(1e9, 1e9);  // default: resting on the floor
  Eigen::Vector2d clearance = Eigen::Vector2d(0.05, 1.0);
  double min_separation = 1.0;
};

/// Lowest world z of a body of revolution (profile) whose axis is z_axis, origin at 0.
double lowestPoint(const std::vector<ProfilePoint>& profile, const Eigen::Vector3d& z_axis) {
  const double cz = z_axis.z(), sz = std::sqrt(std::max(0.0, 1.0 - cz * cz));
  double lo = 1e9;
  for (const ProfilePoint& p : profile) lo = std::min(lo, p.z * cz - p.r * sz);
  return lo;
}

std::vector<Eigen::Isometry3d> generateRandomPoses(
    const RandomPoseSpec& s, const PipeConfig& pipe,
    const std::vector<std::vector<Eigen::Isometry3d>>& others) {
  Rng rng(streamSeed(s.seed, 0x5EED));
  const std::vector<ProfilePoint> profile = toolJointProfile(pipe.end, pipe.dims);
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < s.count; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int attempt = 0; attempt < 200; ++attempt) {
      const bool hanging = pipe.end == EndLabel::kPinEnd && rng.chance(s.hanging_fraction);
      const bool standing =
          !hanging && s.standing_fraction > 0 && rng.chance(s.standing_fraction);
      const double tilt = hanging    ? M_PI - rng.uniform(0.0, 15.0) * M_PI / 180.0
                          : standing ? rng.uniform(0.0, 5.0) * M_PI / 180.0
                                     : rng.uniform(s.tilt_deg[0], s.tilt_deg[1]) * M_PI / 180.0;
      const double yaw = rng.uniform(0.0, 2.0 * M_PI), roll = rng.uniform(0.0, 2.0 * M_PI);
      const Eigen::Vector3d z(std::sin(tilt) * std::cos(yaw), std::sin(tilt) * std::sin(yaw),
                              std::cos(tilt));
      const Eigen::Vector2d xy(s.centre.x() + rng.uniform(-1.0, 1.0) * s.half_extent.x(),
                               s.centre.y() + rng.uniform(-1.0, 1.0) * s.half_extent.y());
      const double rest = -lowestPoint(profile, z);
      const double h =
          standing ? std::min(rest, rng.uniform(s.standing_height[0], s.standing_height[1]))
                   : rest + rng.uniform(s.clearance[0], s.clearance[1]);
      T = canonicalPose(Eigen::Vector3d(xy.x(), xy.y(), h), z);
      T.rotate(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()));
      bool ok = true;
      for (const auto& other : others)
        if (i < static_cast<int>(other.size()) &&
            (other[i].translation().head<2>() - xy).norm() < s.min_separation)
          ok = false;
      if (ok) break;
    }
    poses.push_back(T);
  }
  return poses;
}

Trajectory parseMotion(const YAML::Node& parent, const Eigen::Isometry3d& pose,
                       const std::string& where, RandomPoseSpec* random_spec, bool* random) {
  Trajectory tr;
  tr.T_world_anchor = pose;
  *random = false;
  const YAML::Node n = parent["motion"];
  if (!n) return tr;
  const std::string w = at(where, "motion");
  if (!n.IsMap()) fail(w, ": expected a map");
  static const std::set<std::string> keys = {"velocity", "period_s", "swing", "random_poses"};
  for (const auto& kv : n)
    if (!keys.count(kv.first.as<std::string>()))
      fail(w, ": unknown key \"", kv.first.as<std::string>(),
           "\" (expected velocity, period_s, swing, random_poses)");
  if (n["velocity"]) tr.velocity = yamlVec3(n, "velocity", w);
  tr.linear_period_s = yamlGetOr<double>(n, "period_s", 0.0, w);
  if (tr.linear_period_s < 0) fail(w, ": period_s: expected >= 0");
  if (n["swing"]) {
    const YAML::Node s = n["swing"];
    const std::string ws = at(w, "swing");
    tr.swing_amplitude_rad = yamlGet<double>(s, "amplitude_deg", ws) * M_PI / 180.0;
    tr.swing_period_s = yamlGet<double>(s, "period_s", ws);
    if (!(tr.swing_period_s > 0)) fail(ws, ": period_s: expected > 0");
    if (s["axis"]) tr.swing_axis = yamlVec3(s, "axis", ws);
    if (tr.swing_axis.norm() < 1e-9) fail(ws, ": axis: expected a non-zero vector");
    tr.swing_axis.normalize();
    if (s["pivot_offset"]) tr.swing_pivot_offset = yamlVec3(s, "pivot_offset", ws);
  }
  if (n["random_poses"]) {
    const YAML::Node r = n["random_poses"];
    const std::string wr = at(w, "random_poses");
    RandomPoseSpec& s = *random_spec;
    s.count = yamlGetOr<int>(r, "count", s.count, wr);
    // The poses are drawn up front: a count near 2^31 ran for minutes and took gigabytes (found
    // by the scene fuzzer). An hour of one pose per 0.1 s is 36000.
    constexpr int kMaxRandomPoses = 100000;
    if (s.count < 1 || s.count > kMaxRandomPoses)
      fail(wr, ": count: expected 1..", kMaxRandomPoses, " (the poses are drawn when the scene "
           "loads)");
    s.interval_s = yamlGetOr<double>(r, "interval_s", s.interval_s, wr);
    if (!(s.interval_s > 0)) fail(wr, ": interval_s: expected > 0");
    s.seed = yamlGetOr<uint64_t>(r, "seed", s.seed, wr);
    s.centre = yamlVector<2>(yamlChild(r, "centre", wr), "centre", wr);
    if (r["half_extent"]) s.half_extent = yamlVector<2>(r["half_extent"], "half_extent", wr);
    if (r["tilt_deg"]) s.tilt_deg = yamlVector<2>(r["tilt_deg"], "tilt_deg", wr);
    if (r["clearance"]) s.clearance = yamlVector<2>(r["clearance"], "clearance", wr);
    s.hanging_fraction = yamlGetOr<double>(r, "hanging_fraction", s.hanging_fraction, wr);
    s.standing_fraction = yamlGetOr<double>(r, "standing_fraction", s.standing_fraction, wr);
    if (!(s.standing_fraction >= 0 && s.standing_fraction <= 1))
      fail(wr, ": standing_fraction: expected 0..1");
    if (r["standing_height"]) {
      s.standing_height = yamlVector<2>(r["standing_height"], "standing_height", wr);
      if (!(s.standing_height[0] > 0 && s.standing_height[0] <= s.standing_height[1] &&
            s.standing_height[1] < 100))
        fail(wr, ": standing_height: expected [min, max] with 0 < min <= max < 100 [m]");
    }
    s.min_separation = yamlGetOr<double>(r, "min_separation", s.min_separation, wr);
    tr.pose_interval_s = s.interval_s;
    *random = true;
  }
  return tr;
}

void parseDimensions(const YAML::Node& n, ToolJointDimensions* d, const std::string& where) {
  if (!n) return;
  if (!n.IsMap()) fail(where, ": expected a map of ToolJointDimensions fields");
  std::map<std::string, double*> f = {{"tube_od", &d->tube_od},
                                      {"tube_id", &d->tube_id},
                                      {"tool_joint_od", &d->tool_joint_od},
                                      {"tool_joint_id", &d->tool_joint_id},
                                      {"elevator_taper_deg", &d->elevator_taper_deg},
                                      {"pin_tong_length", &d->pin_tong_length},
                                      {"box_tong_length", &d->box_tong_length},
                                      {"pin_length", &d->pin_length},
                                      {"pin_large_diameter", &d->pin_large_diameter},
                                      {"pin_taper", &d->pin_taper},
                                      {"box_counterbore_diameter", &d->box_counterbore_diameter},
                                      {"box_thread_depth", &d->box_thread_depth},
                                      {"threads_per_inch", &d->threads_per_inch},
                                      {"thread_height", &d->thread_height},
                                      {"tube_length", &d->tube_length}};
  for (const auto& kv : n) {
    const std::string key = kv.first.as<std::string>();
    if (key == "threads") {
      d->threads = yamlAs<bool>(kv.second, key, where);
      continue;
    }
    auto it = f.find(key);
    if (it == f.end()) fail(where, ": unknown tool-joint dimension \"", key, "\"");
    *it->second = yamlAs<double>(kv.second, key, where);
  }
}

void addRoom(const YAML::Node& room, SceneConfig* cfg, const std::string& where) {
  const Eigen::Vector3d size = yamlVec3(room, "size", where);
  if (!(size.minCoeff() > 0)) fail(where, ": size: expected 3 positive numbers");
  const std::string floor = yamlGetOr<std::string>(room, "floor", "concrete", where);
  const std::string walls = yamlGetOr<std::string>(room, "walls", "wall_paint", where);
  checkMaterial(cfg->materials, floor, where + " (floor)");
  checkMaterial(cfg->materials, walls, where + " (walls)");
  auto add = [&](const std::string& name, double sx, double sy, const Eigen::Vector3d& t,
                 const Eigen::Matrix3d& R, const std::string& mat) {
    ObjectConfig o;
    o.name = name;
    o.shape = Shape::plane(sx, sy);
    o.material = mat;
    o.motion.T_world_anchor.linear() = R;
    o.motion.T_world_anchor.translation() = t;
    cfg->objects.push_back(o);
  };
  const double sx = size.x(), sy = size.y(), sz = size.z();
  // Floor (normal +z), walls with their plane normal (local z) pointing into the cell.
  add("floor", 0.0, 0.0, Eigen::Vector3d(sx / 2, sy / 2, 0.0), Eigen::Matrix3d::Identity(), floor);
  auto R_from_z = [](const Eigen::Vector3d& z) { return canonicalRotation(z); };
  add("wall_west", sz * 2, sy, Eigen::Vector3d(0, sy / 2, sz / 2),
      R_from_z(Eigen::Vector3d::UnitX()), walls);
  add("wall_east", sz * 2, sy, Eigen::Vector3d(sx, sy / 2, sz / 2),
      R_from_z(-Eigen::Vector3d::UnitX()), walls);
  add("wall_south", sx, sz * 2, Eigen::Vector3d(sx / 2, 0, sz / 2),
      R_from_z(Eigen::Vector3d::UnitY()), walls);
  add("wall_north", sx, sz * 2, Eigen::Vector3d(sx / 2, sy, sz / 2),
      R_from_z(-Eigen::Vector3d::UnitY()), walls);
}

CalibrationTargetConfig parseCalibrationTarget(const YAML::Node& n, const std::string& w) {
  if (!n.IsMap()) fail(w, ": expected a map");
  static const std::set<std::string> keys = {
      "type",   "squares",   "square_length", "marker_length", "dictionary",
      "margin", "thickness", "hold_s",        "move_s",        "placements"};
  for (const auto& kv : n)
    if (!keys.count(kv.first.as<std::string>()))
      fail(w, ": unknown key \"", kv.first.as<std::string>(), "\"");
  CalibrationTargetConfig c;
  calibration::TargetGeometry& g = c.geometry;
  g.type = calibration::parseTargetType(yamlGet<std::string>(n, "type", w), w + ".type");
  const Eigen::Vector2d sq = yamlVector<2>(yamlChild(n, "squares", w), "squares", w);
  // (Range-checked before the conversion to int: 1e300 squares is no int.)
  if (sq != sq.array().round().matrix() ||
      !(sq.cwiseAbs().maxCoeff() <= calibration::kMaxTargetSquares))
    fail(w, ": squares: expected two whole numbers, at most ", calibration::kMaxTargetSquares);
  g.squares_x = static_cast<int>(sq.x());
  g.squares_y = static_cast<int>(sq.y());
  g.square_length = yamlGet<double>(n, "square_length", w);
  g.marker_length = yamlGetOr<double>(n, "marker_length", g.marker_length, w);
  g.dictionary = yamlGetOr<std::string>(n, "dictionary", g.dictionary, w);
  calibration::validateTarget(g, w);
  c.margin = yamlGetOr<double>(n, "margin", c.margin, w);
  c.thickness = yamlGetOr<double>(n, "thickness", c.thickness, w);
  c.hold_s = yamlGet<double>(n, "hold_s", w);
  c.move_s = yamlGetOr<double>(n, "move_s", c.move_s, w);
  if (!(c.margin >= 0)) fail(w, ".margin = ", c.margin, ": expected >= 0 [m]");
  if (!(c.thickness > 0)) fail(w, ".thickness = ", c.thickness, ": expected > 0 [m]");
  if (!(c.hold_s > 0)) fail(w, ".hold_s = ", c.hold_s, ": expected > 0 [s]");
  if (!(c.move_s >= 0)) fail(w, ".move_s = ", c.move_s, ": expected >= 0 [s]");
  const YAML::Node pl = yamlChild(n, "placements", w);
  if (!pl.IsSequence() || pl.size() == 0)
    fail(w, ".placements: expected a non-empty sequence of poses");
  for (size_t k = 0; k < pl.size(); ++k)
    c.placements.push_back(parsePose(pl[k], w + ".placements[" + std::to_string(k) + "]"));
  return c;
}

/// The scene's static and moving objects (not pipes), into cfg->objects.
void parseObjects(const YAML::Node& objs, SceneConfig* cfgp, const std::string& src) {
  SceneConfig& cfg = *cfgp;
  if (!objs.IsSequence()) fail(src, ": objects: expected a sequence");
  for (size_t i = 0; i < objs.size(); ++i) {
    const YAML::Node n = objs[i];
    const std::string w = src + ": objects[" + std::to_string(i) + "]";
    ObjectConfig o;
    o.name = yamlGetOr<std::string>(n, "name", "object" + std::to_string(i), w);
    const std::string type = yamlGet<std::string>(n, "type", w);
    if (type == "box") {
      o.shape = Shape::box(yamlVec3(n, "size", w));
    } else if (type == "cylinder") {
      const double r = yamlGet<double>(n, "radius", w), h = yamlGet<double>(n, "height", w);
      if (!(r > 0) || !(h > 0)) fail(w, ": radius and height: expected > 0");
      o.shape = Shape::cylinder(r, 0.0, h);
    } else if (type == "plane") {
      const Eigen::Vector2d s = yamlVector<2>(yamlChild(n, "size", w), "size", w);
      if (s.minCoeff() < 0) fail(w, ": size: expected >= 0 (0 = unbounded)");
      o.shape = Shape::plane(s.x(), s.y());
    } else {
      fail(w, ": type: unknown object type \"", type, "\" (expected box, cylinder, plane)");
    }
    o.material = checkMaterial(cfg.materials, yamlGet<std::string>(n, "material", w), w);
    const Eigen::Isometry3d pose = parsePose(yamlChild(n, "pose", w), w + ".pose");
    RandomPoseSpec rs;
    bool random = false;
    o.motion = parseMotion(n, pose, w, &rs, &random);
    if (random) fail(w, ".motion: random_poses is only supported for tool_joint pipes");
    cfg.objects.push_back(o);
  }
}

SceneConfig parseRoot(const YAML::Node& root, const std::string& src) {
  if (!root.IsMap()) fail(src, ": expected a map at the top level");
  static const std::set<std::string> top = {"name",      "description", "work_zone",
                                            "room",      "light",       "materials",
                                            "objects",   "pipes",       "calibration_target"};
  for (const auto& kv : root)
    if (!top.count(kv.first.as<std::string>()))
      fail(src, ": unknown top-level key \"", kv.first.as<std::string>(), "\"");
  SceneConfig cfg;
  cfg.name = yamlGet<std::string>(root, "name", src);
  cfg.description = yamlGetOr<std::string>(root, "description", "", src);
  const YAML::Node wz = yamlChild(root, "work_zone", src);
  cfg.work_zone.min = yamlVec3(wz, "min", src + ": work_zone");
  cfg.work_zone.max = yamlVec3(wz, "max", src + ": work_zone");
  if (!(cfg.work_zone.max.array() > cfg.work_zone.min.array()).all())
    fail(src, ": work_zone: max must exceed min in x, y and z");
  if (root["light"]) {
    const std::string w = src + ": light";
    cfg.light.direction = yamlVec3(root["light"], "direction", w);
    if (cfg.light.direction.norm() < 1e-9) fail(w, ": direction: expected a non-zero vector");
    cfg.light.direction.normalize();
    cfg.light.ambient = yamlGetOr<double>(root["light"], "ambient", cfg.light.ambient, w);
    if (!(cfg.light.ambient >= 0.0 && cfg.light.ambient <= 1.0))
      fail(w, ": ambient: expected a fraction in [0, 1], got ", cfg.light.ambient);
    if (root["light"]["tint"]) {
      cfg.light.tint = yamlVec3(root["light"], "tint", w);
      for (int c = 0; c < 3; ++c)
        if (!(cfg.light.tint[c] >= 0.0 && cfg.light.tint[c] <= 4.0))
          fail(w, ": tint: expected three gains [b, g, r] in [0, 4], got ", cfg.light.tint[c]);
    }
  }
  cfg.materials = builtinMaterials();
  if (root["materials"]) {
    if (!root["materials"].IsMap()) fail(src, ": materials: expected a map name -> material");
    for (const auto& kv : root["materials"]) {
      const std::string name = kv.first.as<std::string>();
      cfg.materials[name] = parseMaterial(kv.second, name, src + ": materials." + name);
    }
  }
  if (root["room"]) addRoom(root["room"], &cfg, src + ": room");
  if (root["calibration_target"])
    cfg.calibration_target =
        parseCalibrationTarget(root["calibration_target"], src + ": calibration_target");

  if (root["objects"]) parseObjects(root["objects"], &cfg, src);

  // A calibration scene may have no pipes; every other scene needs at least one.
  if (cfg.calibration_target && !root["pipes"]) return cfg;
  const YAML::Node pipes = yamlChild(root, "pipes", src);
  if (!pipes.IsSequence() || pipes.size() == 0) fail(src, ": pipes: expected a non-empty sequence");
  std::vector<std::vector<Eigen::Isometry3d>> random_sets;
  std::set<std::string> names;
  PipeCatalog catalog;  // loaded at the first pipe_type
  for (size_t i = 0; i < pipes.size(); ++i) {
    const YAML::Node n = pipes[i];
    const std::string w = src + ": pipes[" + std::to_string(i) + "]";
    PipeConfig p;
    p.name = yamlGetOr<std::string>(n, "name", "pipe" + std::to_string(i), w);
    if (!names.insert(p.name).second) fail(w, ": name: duplicate pipe name \"", p.name, "\"");
    const std::string type = yamlGet<std::string>(n, "type", w);
    if (type == "tool_joint") {
      p.kind = PipeConfig::Kind::kToolJoint;
      p.end = parseEndLabel(yamlGet<std::string>(n, "end", w), w + ".end");
    } else if (type == "pipe") {
      p.kind = PipeConfig::Kind::kPipe;
      p.length = yamlGet<double>(n, "length", w);
    } else {
      fail(w, ": type: unknown pipe type \"", type, "\" (expected tool_joint or pipe)");
    }
    if (n["pipe_type"]) {
      // A pipe catalogue entry (sceneCatalogPath: the package's, beside config/scenes/), then
      // the dimensions below as overrides (a worn or off-nominal joint).
      p.pipe_type = yamlGet<std::string>(n, "pipe_type", w);
      if (catalog.path.empty()) catalog = loadPipeCatalog(sceneCatalogPath(src));
      try {
        p.dims = catalog.at(p.pipe_type).dims;
      } catch (const InputError& e) {
        fail(w, ".pipe_type: ", e.what());
      }
    }
    parseDimensions(n["dimensions"], &p.dims, w + ".dimensions");
    if (n["tube_length"]) p.dims.tube_length = yamlGet<double>(n, "tube_length", w);
    try {
      toolJointProfile(EndLabel::kBoxEnd, p.dims);
    } catch (const InputError& e) {
      fail(w, ".dimensions: ", e.what());
    }
    if (p.kind == PipeConfig::Kind::kPipe) {
      const double min_len =
          p.dims.box_tong_length + p.dims.pin_tong_length + 2 * p.dims.taperLength() + 0.1;
      if (!(p.length > min_len))
        fail(w, ": length: expected > ", min_len, " m (both tool joints and some tube)");
    }
    p.material =
        checkMaterial(cfg.materials, yamlGetOr<std::string>(n, "material", p.material, w), w);
    p.mud = yamlGetOr<bool>(n, "mud", true, w);
    p.ground_truth = yamlGetOr<bool>(n, "ground_truth", true, w);
    const Eigen::Isometry3d pose = parsePose(yamlChild(n, "pose", w), w + ".pose");
    RandomPoseSpec rs;
    bool random = false;
    p.motion = parseMotion(n, pose, w, &rs, &random);
    if (random) {
      if (p.kind != PipeConfig::Kind::kToolJoint)
        fail(w, ".motion: random_poses is only supported for tool_joint pipes");
      p.motion.pose_sequence = generateRandomPoses(rs, p, random_sets);
      random_sets.push_back(p.motion.pose_sequence);
    }
    cfg.pipes.push_back(p);
  }
  return cfg;
}

/// parseRoot with yaml-cpp's own exceptions (a map or a list where a key or a string belongs:
/// `{a: 1}: 2`) as the InputError every other mistake in the file gives.
SceneConfig parseChecked(const YAML::Node& root, const std::string& source) {
  try {
    return parseRoot(root, source);
  } catch (const YAML::Exception& e) {
    fail(source, ": ", e.what());
  }
}

}  // namespace

SceneConfig parseSceneConfig(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    fail(source, ": YAML syntax error: ", e.what());
  }
  return parseChecked(root, source);
}

std::string sceneCatalogPath(const std::string& scene_path) {
  return (std::filesystem::path(scene_path).parent_path() / ".." / "pipe_catalog.yaml").string();
}

SceneConfig loadSceneConfig(const std::string& path) {
  return parseChecked(yamlLoadFile(path), path);
}

namespace {

std::vector<MudPatch> makeMud(Rng& rng, const SensorEffects& fx, double z_lo, double z_hi) {
  std::vector<MudPatch> mud;
  const int n = fx.min_mud_patches +
                static_cast<int>(rng.uniform() * (fx.max_mud_patches - fx.min_mud_patches + 1));
  for (int i = 0; i < n; ++i) {
    MudPatch m;
    m.phi_center = rng.uniform(-M_PI, M_PI);
    m.phi_half_width = rng.uniform(0.2, 0.9);
    m.z_center = rng.uniform(z_lo, z_hi);
    m.z_half_width = rng.uniform(0.02, 0.08);
    m.reflectivity_factor = rng.uniform(0.15, 0.5);
    mud.push_back(m);
  }
  return mud;
}

}  // namespace

namespace {

/// Texels per printed square of the simulated target: 2 mm on the 0.24 m squares, finer than the
/// 16 colour samples per HD pixel need at 3 m (about 1.2 mm apart); the squares' edges fall on
/// texel boundaries whatever the resolution.
constexpr int kTargetTexelsPerSquare = 120;

void addCalibrationTarget(const CalibrationTargetConfig& c, Scene* scene) {
  const Eigen::Vector2d size = calibration::targetSize(c.geometry);
  SceneObject o;
  o.name = "calibration_target";
  o.shape = Shape::box(Eigen::Vector3d(size.x() + 2 * c.margin, size.y() + 2 * c.margin,
                                       c.thickness));
  o.material = Material{"paper", kPaperReflectivity, {{255, 255, 255}}};
  o.texture = std::make_shared<calibration::TargetTexture>(c.geometry, kTargetTexelsPerSquare);
  Trajectory traj;
  traj.key_poses = c.placements;
  traj.hold_s = c.hold_s;
  traj.move_s = c.move_s;
  o.trajectory = scene->addTrajectory(traj);
  // Printed face (local +z) at the target frame's z = 0.
  o.T_anchor_object = Eigen::Translation3d(0.0, 0.0, -c.thickness / 2.0) * Eigen::Isometry3d::Identity();
  scene->objects.push_back(o);
}

}  // namespace

Scene buildScene(const SceneConfig& cfg, const SensorEffects& fx, uint32_t seed) {
  Scene scene;
  scene.light = cfg.light;
  for (const ObjectConfig& oc : cfg.objects) {
    SceneObject o;
    o.name = oc.name;
    o.shape = oc.shape;
    o.material = cfg.materials.at(oc.material);
    o.trajectory = scene.addTrajectory(oc.motion);
    o.T_anchor_object = o.trajectory < 0 ? oc.motion.T_world_anchor : Eigen::Isometry3d::Identity();
    scene.objects.push_back(o);
  }
  for (size_t pi = 0; pi < cfg.pipes.size(); ++pi) {
    const PipeConfig& pc = cfg.pipes[pi];
    Rng rng(streamSeed(seed, kStreamWear, pi));
    ToolJointDimensions dims = pc.dims;
    if (fx.wear) {
      dims.tool_joint_od -= rng.uniform(0.0, fx.max_od_wear);
      dims.box_tong_length -= rng.uniform(0.0, fx.max_tong_wear);
      dims.pin_tong_length -= rng.uniform(0.0, fx.max_tong_wear);
    }
    const int traj = scene.addTrajectory(pc.motion);
    // T_anchor_X for a part at T_end_X (end frame of the anchor = the pipe's pose).
    auto anchored = [&](const Eigen::Isometry3d& T_pose_x) {
      return traj < 0 ? Eigen::Isometry3d(pc.motion.T_world_anchor * T_pose_x) : T_pose_x;
    };
    const Material& mat = cfg.materials.at(pc.material);
    auto addJoint = [&](EndLabel label, const Eigen::Isometry3d& T_pose_end, double tube_len) {
      ToolJointDimensions d = dims;
      d.tube_length = tube_len;
      SceneObject o;
      o.name = pc.name + "/" + labelName(label);
      o.shape = Shape::revolvedProfile(toolJointProfile(label, d));
      o.material = mat;
      o.trajectory = traj;
      o.T_anchor_object = anchored(T_pose_end);
      SceneEnd e;
      e.label = label;
      e.pipe = pc.name;
      e.trajectory = traj;
      e.T_anchor_end = o.T_anchor_object;
      e.nominal = pc.dims;
      e.rendered = d;
      e.ground_truth = pc.ground_truth;
      const double tong = label == EndLabel::kBoxEnd ? d.box_tong_length : d.pin_tong_length;
      e.region_z_min = -(tong + d.taperLength());
      e.region_z_max = label == EndLabel::kBoxEnd ? 0.0 : d.pin_length;
      e.region_radius = d.tool_joint_od / 2;
      if (fx.mud && pc.mud) o.mud = makeMud(rng, fx, e.region_z_min, e.region_z_max);
      o.end = static_cast<int>(scene.ends.size());
      e.object = static_cast<int>(scene.objects.size());
      scene.objects.push_back(o);
      scene.ends.push_back(e);
    };
    if (pc.kind == PipeConfig::Kind::kToolJoint) {
      addJoint(pc.end, Eigen::Isometry3d::Identity(), dims.tube_length);
    } else {
      const double stub = 0.05;  // tube kept on each joint; the tube cylinder overlaps it
      addJoint(EndLabel::kBoxEnd, Eigen::Isometry3d::Identity(), stub);
      Eigen::Isometry3d T_box_pin = Eigen::Isometry3d::Identity();
      T_box_pin.translation() = Eigen::Vector3d(0, 0, -pc.length);
      T_box_pin.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
      addJoint(EndLabel::kPinEnd, T_box_pin, stub);
      SceneObject tube;
      tube.name = pc.name + "/tube";
      const double z_hi = -(dims.box_tong_length + dims.taperLength()) - 0.01;
      const double z_lo = -pc.length + dims.pin_tong_length + dims.taperLength() + 0.01;
      tube.shape = Shape::cylinder(dims.tube_od / 2, z_lo, z_hi);
      tube.material = mat;
      tube.trajectory = traj;
      tube.T_anchor_object = anchored(Eigen::Isometry3d::Identity());
      scene.objects.push_back(tube);
    }
  }
  if (cfg.calibration_target) addCalibrationTarget(*cfg.calibration_target, &scene);
  return scene;
}

}  // namespace drill_pipe_pose::sim
