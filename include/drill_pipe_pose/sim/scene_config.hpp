#pragma once
// Scene files (config/scenes/<name>.yaml): what a scenario contains, independent of the rig
// (config/rigs/*.yaml) and of the sensor profile. Schema (every key type-checked; errors name the
// file, the key path and what was expected):
//
//   name: thesis_vertical
//   description: "..."                       # optional
//   work_zone: {min: [x, y, z], max: [x, y, z]}   # [m] world, axis-aligned
//   room: {size: [10, 10, 5.5], floor: concrete, walls: wall_paint}   # optional: floor z = 0
//                                            # and four walls of the cell [0, sx] x [0, sy]
//   light: {direction: [0.3, 0.2, -1], ambient: 0.35,                 # optional
//           tint: [1, 1, 1]}                 # optional: the light's colour, a gain per channel
//                                            # (B, G, R order, each 0..4) on every surface
//   materials:                               # optional, added to / overriding the built-ins
//     my_paint: {reflectivity: 0.6, bgr: [20, 200, 230]}
//   objects:                                 # optional clutter
//     - {name: barrel, type: cylinder, radius: 0.29, height: 0.88, pose: POSE, material: M}
//     - {name: crate, type: box, size: [0.6, 0.4, 0.5], pose: POSE, material: M}   # pose = centre
//     - {name: catwalk, type: plane, size: [2, 10], pose: POSE, material: M}  # 0 = unbounded
//   pipes:                                   # optional only in a scene with a calibration_target
//     - name: box_sample
//       type: tool_joint            # a single tool joint with a short tube (lab sample) ...
//       end: box_end                # box_end | pin_end
//       pose: POSE                  # T_world_end: the pipe-end frame (docs/conventions.md)
//       tube_length: 0.25           # optional [m]: tube left below the taper
//     - name: drill_pipe
//       type: pipe                  # ... or a whole pipe: box end, tube, pin end
//       pose: POSE                  # T_world_end of its BOX end; the pin end lies `length`
//       length: 6.0                 # [m] further along -z, its z pointing the other way
//       dimensions: {tool_joint_od: 0.1683, ...}   # optional, any ToolJointDimensions field
//       material: yellow_paint
//       mud: true                   # optional (the sensor profile may still switch mud off)
//       ground_truth: true          # optional; false: a distractor (rendered, detected, not
//                                   # in groundTruth())
//       motion: MOTION              # optional
//
//   calibration_target:                      # optional: a printed board carried through the zone
//     type: charuco                          # charuco | chessboard
//     squares: [5, 5]                        # printed squares along target x, y
//     square_length: 0.24                    # [m]
//     marker_length: 0.18                    # [m] charuco only
//     dictionary: DICT_4X4_50                # charuco only
//     margin: 0.06                           # optional [m] white paper around the squares
//     thickness: 0.005                       # optional [m] the plate (printed face = local +z)
//     hold_s: 2.0                            # [s] each placement is held this long ...
//     move_s: 1.0                            # optional [s] ... then moves linearly to the next
//     placements: [POSE, ...]                # T_world_target (core/calibration/target.hpp frame)
//
//   POSE   = {translation: [x, y, z], rpy_deg: [roll, pitch, yaw]}   # R = Rz(yaw) Ry(pitch)
//   Rx(roll)
//          | {translation: [...], quaternion: [x, y, z, w]}
//          | {translation: [...], z_axis: [x, y, z]}                  # canonical roll
//   MOTION = {velocity: [vx, vy, vz], period_s: 5,                    # [m/s]; wraps every period
//             swing: {amplitude_deg: 3, period_s: 4, axis: [1, 0, 0], pivot_offset: [0, 0, 4]},
//             random_poses: {count: 60, interval_s: 2, seed: 7, centre: [x, y],
//                            half_extent: [1, 1], tilt_deg: [0, 90], hanging_fraction: 0.3,
//                            clearance: [0.05, 1.0], min_separation: 1.0,
//                            standing_fraction: 0, standing_height: [0.15, 0.7]}}
//
// random_poses (tool_joint only) draws `count` (1..100000) poses held `interval_s` each
// (cycling): position uniform in centre +- half_extent, tilt from vertical uniform in
// tilt_deg, any yaw and roll; a pin end hangs (points down, tilt <= 15 deg) with probability
// hanging_fraction; else it stands upright (tilt <= 5 deg) in the floor with probability
// standing_fraction (default 0), its origin standing_height above the floor (default, or when
// higher: resting on the floor), the rest below it as a stump in the slips; else the height puts
// the lowest point of the joint `clearance` above the floor;
// origins keep min_separation [m] (horizontal) from earlier random-pose pipes at the same
// index. Seeded by the file's seed only, so the ground truth does not depend on the simulator
// seed.

#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"
#include "drill_pipe_pose/sim/scene.hpp"
#include "drill_pipe_pose/sim/sensor_model.hpp"

namespace drill_pipe_pose::sim {

/// Axis-aligned box in the world frame [m]: where pipe ends are expected.
struct WorkZone {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  bool contains(const Eigen::Vector3d& p_world) const {
    return (p_world.array() >= min.array()).all() && (p_world.array() <= max.array()).all();
  }
};

/// A clutter / environment object of a scene file.
struct ObjectConfig {
  std::string name;
  Shape shape;  ///< local frame as Shape's factory functions define it
  std::string material;
  Trajectory motion;  ///< motion.T_world_anchor = the object's pose
};

/// A pipe of a scene file: a single tool joint or a whole pipe.
struct PipeConfig {
  enum class Kind { kToolJoint, kPipe };
  std::string name;
  Kind kind = Kind::kToolJoint;
  EndLabel end = EndLabel::kBoxEnd;  ///< tool_joint only
  ToolJointDimensions dims;          ///< nominal
  std::string pipe_type;  ///< the catalogue entry its dims came from ("": the defaults)
  double length = 9.0;               ///< [m] whole pipe: box end face to pin shoulder
  std::string material = "yellow_paint";
  bool mud = true;
  bool ground_truth = true;  ///< false: a distractor, rendered and detected but not scored
  Trajectory motion;         ///< T_world_anchor = T_world_end (tool_joint) / T_world_box_end (pipe)
};

/// The calibration target of a scene file: a thin white plate carrying the printed squares,
/// placed at each placement for hold_s, moving linearly for move_s between them.
struct CalibrationTargetConfig {
  calibration::TargetGeometry geometry;
  double margin = 0.06;      ///< [m] white paper beyond the squares
  double thickness = 0.005;  ///< [m]
  double hold_s = 2.0;       ///< [s]
  double move_s = 0.0;       ///< [s]
  std::vector<Eigen::Isometry3d> placements;  ///< T_world_target
  /// Start of placement k's hold [s]; the hold lasts hold_s.
  double holdStart(size_t k) const { return static_cast<double>(k) * (hold_s + move_s); }
  /// Middle of placement k's hold [s].
  double holdMiddle(size_t k) const { return holdStart(k) + hold_s / 2.0; }
};

struct SceneConfig {
  std::string name;
  std::string description;
  WorkZone work_zone;
  Light light;
  std::map<std::string, Material> materials;  ///< built-ins plus the file's
  std::vector<ObjectConfig> objects;          ///< room included
  std::vector<PipeConfig> pipes;
  std::optional<CalibrationTargetConfig> calibration_target;
};

/// The built-in materials (concrete, wall_paint, yellow_paint, grey_paint, dark_steel,
/// rusty_steel, barrel_blue, cardboard, hi_vis, catwalk_steel, black_rubber).
std::map<std::string, Material> builtinMaterials();

/// Loads and validates a scene file; InputError names the file, the key and what was expected.
SceneConfig loadSceneConfig(const std::string& path);
/// The pipe catalogue a scene's `pipe_type:` names an entry of: the package's
/// config/pipe_catalog.yaml, one folder above the scene's (config/scenes/).
std::string sceneCatalogPath(const std::string& scene_path);
/// The same from YAML text; `source` names it in errors.
SceneConfig parseSceneConfig(const std::string& yaml_text, const std::string& source);

/// Builds the rendered scene: nominal tool joints worn as `effects` says (seeded by `seed` and
/// the pipe index), mud patches, whole pipes split into box joint + tube + pin joint, the
/// calibration target as a textured plate (the last object, named "calibration_target").
Scene buildScene(const SceneConfig& config, const SensorEffects& effects, uint32_t seed);

}  // namespace drill_pipe_pose::sim
