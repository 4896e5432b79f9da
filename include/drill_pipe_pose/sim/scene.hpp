#pragma once
// The simulated world: objects (floor, walls, clutter, tool joints, whole pipes), each with a pose
// (possibly moving), a material and optional mud patches, and the ground-truth pipe-end frames.
// World frame: REP 103, metres, z up. Everything here is ROS-free.
//
// Two levels:
//  - SceneConfig (scene_config.hpp): what a scene file says (nominal tool joints, motions).
//  - Scene (this file): what is rendered, built from a SceneConfig by buildScene() with the
//    sensor profile's tool-joint wear and mud applied (so the rendered shape is never the
//    nominal model the estimator fits).

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"
#include "drill_pipe_pose/sim/geometry.hpp"

namespace drill_pipe_pose::sim {

/// Surface properties.
struct Material {
  std::string name;
  double reflectivity = 0.5;  ///< diffuse IR reflectivity for the depth sensor, [0, 1]
  std::array<uint8_t, 3> bgr{{128, 128, 128}};  ///< albedo for the colour image (B, G, R)
};

/// A patch of mud on a body of revolution, in its local cylindrical coordinates.
struct MudPatch {
  double phi_center = 0.0;           ///< [rad] angle about the local z axis (from local x)
  double phi_half_width = 0.5;       ///< [rad]
  double z_center = 0.0;             ///< [m] along the local z axis
  double z_half_width = 0.05;        ///< [m]
  double reflectivity_factor = 0.3;  ///< multiplies the material's reflectivity inside the patch
};

/// IR reflectivity of a printed calibration target: white paper (the sensor check's calibration,
/// docs/sensor_check.md: paper = 0.8) and black toner (about 0.05, as black rubber).
constexpr double kPaperReflectivity = 0.8;
constexpr double kBlackPrintReflectivity = 0.05;

/// Mud colour (B, G, R): dried drilling mud, brown-grey.
constexpr std::array<uint8_t, 3> kMudBgr{{45, 65, 85}};

/// A pose as a function of time: T_world_anchor(t). Combines (all optional):
///  - a base pose, or a sequence of base poses held for `pose_interval_s` each (cycling),
///  - a linear displacement velocity * tau, tau = t (or fmod(t, linear_period_s) when > 0),
///  - a pendulum swing: rotation by swing_amplitude * sin(2 pi t / swing_period_s) about
///    `swing_axis` (world) through the pivot = anchor origin + `swing_pivot_offset` (world).
struct Trajectory {
  Eigen::Isometry3d T_world_anchor = Eigen::Isometry3d::Identity();  ///< pose at t = 0
  std::vector<Eigen::Isometry3d> pose_sequence;        ///< if non-empty, replaces T_world_anchor
  double pose_interval_s = 1.0;                        ///< [s] each sequence pose is held this long
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< [m/s] world
  double linear_period_s = 0.0;                        ///< [s] 0: no wrap
  double swing_amplitude_rad = 0.0;                    ///< [rad]
  double swing_period_s = 0.0;                         ///< [s]
  Eigen::Vector3d swing_axis = Eigen::Vector3d::UnitX();            ///< world, unit
  Eigen::Vector3d swing_pivot_offset = Eigen::Vector3d(0, 0, 3.0);  ///< [m] world
  /// If non-empty, replaces T_world_anchor and pose_sequence: each key pose held `hold_s`, then
  /// `move_s` of linear motion (translation linear, rotation slerp) to the next; the last pose is
  /// held for ever. Key pose k is held over [k (hold_s + move_s), k (hold_s + move_s) + hold_s).
  std::vector<Eigen::Isometry3d> key_poses;
  double hold_s = 1.0, move_s = 0.0;  ///< [s]

  bool isStatic() const {
    return pose_sequence.empty() && key_poses.empty() && velocity.isZero(0) &&
           swing_amplitude_rad == 0.0;
  }
  /// T_world_anchor at time t [s].
  Eigen::Isometry3d pose(double t) const;
};

/// One rendered object.
struct SceneObject {
  std::string name;
  Shape shape;
  Material material;
  std::vector<MudPatch> mud;  ///< only on bodies of revolution
  int trajectory = -1;        ///< index into Scene::trajectories; -1: static
  /// T_anchor_object for moving objects; T_world_object when trajectory == -1.
  Eigen::Isometry3d T_anchor_object = Eigen::Isometry3d::Identity();
  int end = -1;  ///< index into Scene::ends when this object is a tool joint
  /// A printed calibration target on the local +z face (a box): texture coordinates = local
  /// (x, y). Inside the printed squares the albedo sets the colour (albedo * 255, grey) and the
  /// IR reflectivity (kBlackPrintReflectivity .. kPaperReflectivity); the colour image
  /// supersamples its pixels.
  std::shared_ptr<const calibration::TargetTexture> texture;
};

/// A ground-truth pipe end (tool joint) in the scene.
struct SceneEnd {
  EndLabel label = EndLabel::kBoxEnd;
  std::string pipe;  ///< name of the pipe it belongs to
  int trajectory = -1;
  Eigen::Isometry3d T_anchor_end = Eigen::Isometry3d::Identity();  ///< as SceneObject
  int object = -1;  ///< its tool-joint object (local frame = the end frame)
  /// Axial extent of the detector's region in the end frame [m]: from the end of the elevator
  /// taper to the end face (box) or pin nose (pin), of the RENDERED joint.
  double region_z_min = 0.0, region_z_max = 0.0;
  double region_radius = 0.0;    ///< [m] tool-joint OD / 2 (rendered)
  ToolJointDimensions nominal;   ///< from the scene file
  ToolJointDimensions rendered;  ///< with wear applied
  /// Scored end (published as ground truth); false for distractor pipes (still rendered and
  /// detected).
  bool ground_truth = true;
};

/// Directional light for the colour image.
struct Light {
  Eigen::Vector3d direction = Eigen::Vector3d(0.3, 0.2, -1.0).normalized();  ///< travel, world
  double ambient = 0.35;  ///< ambient fraction [0, 1]
  /// Per-channel gain on every surface's colour, B, G, R order [0, 4]: the light's own colour
  /// (1, 1, 1: white; a sodium floodlight is strong in red and green, weak in blue).
  Eigen::Vector3d tint = Eigen::Vector3d::Ones();
};

/// The result of a ray cast in the world.
struct SceneHit {
  double t = 0.0;                                      ///< [m] along the (unit) ray
  Eigen::Vector3d n_world = Eigen::Vector3d::UnitZ();  ///< outward unit normal, world
  Eigen::Vector3d p_local = Eigen::Vector3d::Zero();   ///< hit point in the object's frame [m]
  int object = -1;                                     ///< index into Scene::objects
  float reflectivity = 0.0f;                           ///< with mud applied
  std::array<uint8_t, 3> bgr{{0, 0, 0}};               ///< albedo with mud applied
};

/// Object poses at one instant.
struct SceneSnapshot {
  double t = 0.0;
  std::vector<Eigen::Isometry3d> T_world_object;
  std::vector<Eigen::Isometry3d> T_object_world;
  std::vector<Eigen::AlignedBox3d> world_bounds;
};

class Scene {
 public:
  std::vector<Trajectory> trajectories;
  std::vector<SceneObject> objects;
  std::vector<SceneEnd> ends;
  Light light;

  /// Index of a new trajectory (static ones are not stored: returns -1).
  int addTrajectory(const Trajectory& traj);
  bool isDynamic(size_t object) const { return objects[object].trajectory >= 0; }
  /// Pose of every object at time t [s].
  SceneSnapshot snapshot(double t) const;
  /// T_world_object of one object at time t.
  Eigen::Isometry3d objectPose(size_t object, double t) const;
  /// Exact (non-canonical roll) pose of end `end` at time t: T_world_end.
  Eigen::Isometry3d endPose(size_t end, double t) const;

  /// Nearest hit among `subset` (object indices; all objects when null) with t in (t_min,
  /// t_max), ray in world coordinates. Fills material and mud of the hit.
  bool intersect(const Ray& ray_world, const SceneSnapshot& snap, const std::vector<int>* subset,
                 double t_min, double t_max, SceneHit* hit) const;
};

}  // namespace drill_pipe_pose::sim
