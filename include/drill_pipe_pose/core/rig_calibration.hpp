#pragma once
// The rig calibration file (docs/conventions.md, "Rig file"): one YAML file per rig with `world ->
// <cam>_link` for every camera (translation [m] + unit quaternion x y z w). One schema, one loader,
// used by the simulator, the launch files (through the rig_tf_publisher node) and the tools.
//
//   world_frame: world            # optional, default "world"
//   cameras:
//     - name: cam1                # unique, [A-Za-z][A-Za-z0-9_]*
//       translation: [4.7, 0.2, 5.0]
//       rotation: [0.0, 0.0, 0.0, 1.0]   # x y z w, unit length (tolerance 1e-3; normalised)
//
// Optional per camera: `sensor: kinect_v2` (the simulator's sensor model name), and the camera's
// depth calibration `depth_offset` [m] (default 0) and `depth_scale` (default 1): its depth image
// reads z_meas = depth_scale * z_true + depth_offset along the depth camera's optical axis, and
// the pose estimator (parameter `rig`) recovers z_true = (z_meas - depth_offset) / depth_scale.
// Optional `weak_return_bias` [m (1/m^2)^4]: the camera's own B of the weak-return bias law
// B max(a, a_min)^-4 (core/kinect_noise.hpp), learned by calibrate_rig from the target's two
// prints where it could be; absent: the sensor's fitted B. Its depth_offset then goes with it
// (the offset at the bias reference a_min once the camera's own law is removed).

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace drill_pipe_pose {

struct CameraCalibration {
  std::string name;
  Eigen::Isometry3d T_world_link = Eigen::Isometry3d::Identity();
  std::string sensor = "kinect_v2";
  double depth_offset = 0.0;  ///< [m] |.| <= kMaxDepthOffset
  double depth_scale = 1.0;   ///< within kDepthScaleRange
  std::optional<double> weak_return_bias;  ///< [m (1/m^2)^4] in [0, kMaxWeakReturnBias]
};

/// Bounds of the depth calibration (a Kinect v2 is off by tens of mm and about 2 %; more is a
/// mistake in the file, e.g. millimetres for metres).
constexpr double kMaxDepthOffset = 0.2;  ///< [m]
constexpr double kMinDepthScale = 0.9, kMaxDepthScale = 1.1;
/// Largest weak-return B: ten times the real sensor's (4.035e-9, 28.5 mm at a_min); more is a
/// mistake in the file, e.g. another unit.
constexpr double kMaxWeakReturnBias = 4e-8;

struct RigCalibration {
  std::string world_frame = "world";
  std::vector<CameraCalibration> cameras;
  /// Index of camera `name`, or -1.
  int find(const std::string& name) const;
};

/// Loads and validates a rig file. Throws InputError naming the file, the camera and the field
/// (unit quaternion, finite numbers, 3 / 4 elements, unique names, at least one camera, the depth
/// calibration within its bounds, world_frame and sensor names of [A-Za-z0-9_][A-Za-z0-9_./-]*),
/// also for a file of the wrong shape (a list where a string belongs, a list as a key).
RigCalibration loadRigCalibration(const std::string& path);
/// The same from YAML text; `source` names it in errors.
RigCalibration parseRigCalibration(const std::string& yaml_text, const std::string& source);
/// YAML text of a calibration (round-trips through parseRigCalibration).
std::string rigCalibrationToYaml(const RigCalibration& rig);

}  // namespace drill_pipe_pose
