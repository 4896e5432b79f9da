#pragma once
// Rig calibration, step 1 of 2: what the cameras saw of the calibration target. One observation =
// one camera at one placement of the target: the target's corners found in that camera's image
// (with their ids) and, when the camera has depth, a sample of the depth pixels on the target.
// The observations file is the one interface between capture (a recorded bag, the simulator, or
// another tool's corner files) and the solver (core/calibration/solver.hpp), so that the same
// solver runs on all of them.
//
// Frames: a camera's frame is the optical frame of the image its corners were found in (for a
// rig camera: the colour camera, <cam>_link == <cam>_rgb_optical_frame); the target frame has its
// origin at the target's centre, x along the rows of squares, y along the columns, z out of the
// printed face (towards a camera that sees it). Units: metres, pixels.

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"

namespace drill_pipe_pose::calibration {

/// Most squares along a side of a target (validateTarget): a printed board has tens; more is a
/// mistake in the file, and their count must stay an int when multiplied.
constexpr int kMaxTargetSquares = 1000;

/// The printed target (core/calibration/target.hpp builds its corner positions and detects it).
struct TargetGeometry {
  enum class Type { kCharuco, kChessboard };
  Type type = Type::kCharuco;
  int squares_x = 5;            ///< squares along target x
  int squares_y = 5;            ///< squares along target y
  double square_length = 0.24;  ///< [m]
  double marker_length = 0.18;  ///< [m] ChArUco only
  std::string dictionary = "DICT_4X4_50";  ///< ChArUco only: an OpenCV predefined dictionary
};

/// Pinhole intrinsics with OpenCV's plumb_bob distortion (k1 k2 p1 p2 k3; all 0: rectified).
struct Intrinsics {
  int width = 0, height = 0;  ///< [px]
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<double> D = std::vector<double>(5, 0.0);
};

/// One camera of the calibration: the image its corners are found in and, optionally, a depth
/// camera rigidly attached to it (for a Kinect: its IR camera; for a camera that IS the depth
/// camera, T_camera_depth = identity and the same intrinsics).
struct CameraSetup {
  std::string name;
  std::string sensor = "kinect_v2";  ///< written to the rig file
  Intrinsics intrinsics;
  std::optional<Intrinsics> depth_intrinsics;
  /// p_camera = T_camera_depth * p_depth (the driver's colour-to-depth TF for a Kinect).
  Eigen::Isometry3d T_camera_depth = Eigen::Isometry3d::Identity();
};

struct CornerObservation {
  int id = 0;  ///< index into targetCorners()
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  ///< [px] in the camera's (distorted) image
};

/// A depth pixel on the target: (u, v) in the depth image, z_meas as the camera read it [m]
/// (corrected for the print's weak-return bias where the capture knows it), and its expected
/// noise [m] (0: the solver's default).
struct DepthSample {
  double u = 0, v = 0, z = 0;
  double sigma = 0;
  /// [1/m^2] the amplitude whose weak-return bias z was corrected for with the sensor's law
  /// (0: z as read), so that the solver can correct it again with the camera's own law.
  double amplitude = 0;
};

/// A depth pixel on the target as the camera read it (no correction), with the amplitude of its
/// return a = reflectivity cos(incidence) / range^2 [1/m^2] measured in the frame's IR image:
/// the evidence for the camera's own weak-return bias law (core/calibration/weak_return_fit.hpp).
/// Taken on both prints, so that every placement shows two amplitude levels.
struct AmplitudeSample {
  double u = 0, v = 0, z = 0;
  double amplitude = 0;  ///< [1/m^2], > 0
};

struct Observation {
  std::string camera;  ///< CameraSetup::name
  int placement = 0;   ///< placement index (same number = same target pose in every camera)
  double stamp = 0.0;  ///< [s] capture time, for messages
  std::vector<CornerObservation> corners;
  std::vector<DepthSample> depth;  ///< empty when the camera has no depth or none was sampled
  /// Empty when the frame had no IR amplitude image (the solver then keeps the sensor's
  /// default bias law for the camera).
  std::vector<AmplitudeSample> amplitude;
};

/// Where the world frame comes from: either one placement of the target at a known world pose
/// (e.g. flat on a surveyed floor mark), or one camera at a known world pose.
struct Anchor {
  std::optional<int> placement;
  std::optional<std::string> camera;
  Eigen::Isometry3d T_world_anchor = Eigen::Isometry3d::Identity();
};

struct ObservationSet {
  std::string world_frame = "world";
  TargetGeometry target;
  Anchor anchor;
  std::vector<CameraSetup> cameras;
  std::vector<Observation> observations;
  /// Index of camera `name`, or -1.
  int findCamera(const std::string& name) const;
};

/// A camera's intrinsics from its CameraInfo (K, plumb_bob D). Throws InputError naming `where`
/// for a missing K or size, or more than 5 non-zero distortion coefficients.
Intrinsics intrinsicsFromCameraInfo(const CameraInfoData& info, const std::string& where);

/// YAML file of an ObservationSet (schema in docs/calibration.md). Throws InputError naming the
/// file, the camera / observation and the field.
ObservationSet loadObservations(const std::string& path);
ObservationSet parseObservations(const std::string& yaml_text, const std::string& source);
std::string observationsToYaml(const ObservationSet& set);
void saveObservations(const ObservationSet& set, const std::string& path);

/// A calibration config (config/calibration/*.yaml): the `world_frame`, `target` and `anchor` of
/// an observations file, nothing else; the cameras and observations come from a recording. An
/// anchor camera is not checked here (the caller knows the cameras). Throws InputError naming
/// the file and the field.
ObservationSet loadCalibrationConfig(const std::string& path);
ObservationSet parseCalibrationConfig(const std::string& yaml_text, const std::string& source);

}  // namespace drill_pipe_pose::calibration
