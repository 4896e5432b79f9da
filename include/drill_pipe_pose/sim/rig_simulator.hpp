#pragma once
// The rig simulator: renders what every sensor node of a rig would publish (depth, optional
// colour, CameraInfos, optional SIMULATED detections) for a scene, with ground truth. ROS-free;
// the rig_simulator node and the simulate_bag tool wrap it.
//
// Frames (docs/conventions.md): <cam>_link == <cam>_rgb_optical_frame (colour camera, z forward);
// <cam>_ir_optical_frame = depth camera, T_link_depth away. The rig file gives the TRUE
// world -> <cam>_link used for rendering; publishedT_world_link() is what TF should carry (it
// differs when the profile injects calibration errors).
//
// Rendering: each camera's static background (floor, walls, static clutter and static pipes) is
// ray cast once per camera and cached (depth, incidence, reflectivity per pixel); per frame only
// the pixels inside the projected bounds of moving objects are re-cast, then the sensor effects
// are applied with random streams seeded from (seed, camera, frame index): frames can be
// rendered in any order and are bit-identical for a seed.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"
#include "drill_pipe_pose/sim/scene.hpp"
#include "drill_pipe_pose/sim/scene_config.hpp"
#include "drill_pipe_pose/sim/sensor_model.hpp"
#include "drill_pipe_pose/sim/simulated_detector.hpp"

namespace drill_pipe_pose::sim {

/// A camera moved at a capture time while its published calibration (TF) stays as it was (a
/// bumped camera). From simulation time t on, the camera renders depth, colour and detections
/// from T_world_link_true * delta, delta = translation * Rz(yaw) Ry(pitch) Rx(roll), in the
/// camera's <cam>_link (the colour optical frame: x right, y down, z along the view).
struct CameraBump {
  std::string camera;
  double t = 0.0;                                         ///< [s] simulation time
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  ///< [m] in <cam>_link
  Eigen::Vector3d rpy_deg = Eigen::Vector3d::Zero();      ///< [deg] roll, pitch, yaw
  Eigen::Isometry3d delta() const;
};

/// "CAM:T:DX,DY,DZ[:ROLL,PITCH,YAW]" (s, m, deg) -> a bump; throws InputError naming the text.
CameraBump parseCameraBump(const std::string& text);

struct SimulatorOptions {
  /// ideal | kinect_v2_calibrated | kinect_v2_field | kinect_v2_uncalibrated
  std::string profile = "kinect_v2_calibrated";
  uint32_t seed = 1;                             ///< every random stream derives from it
  bool simulated_detection = true;               ///< fill SensorFrameData::boxes
  bool color = false;                            ///< render the BGR8 colour image too
  /// Render the IR amplitude image beside the depth (SensorFrameData::amplitude, 16UC1 digital
  /// numbers of the sensor model's amplitude); false: frames without amplitude, as from a
  /// driver that publishes none.
  bool amplitude = true;
  /// Colour image resolution x this (focal lengths and centre x this, colorInfo() too): 2 turns
  /// the Kinect v2's QHD model (960x540) into its HD image (1920x1080, fx = fy = 1081.4,
  /// c = 959.5, 539.5).
  int color_scale = 1;
  /// Directory of <sensor>.yaml files (config/sensors); empty: built-in kinect_v2 only.
  std::string sensor_config_dir;
  /// Stamp of simulation time t = 0 [ns]. ROS time 0 means "latest" to tf2: nodes should set
  /// a real start time (e.g. wall clock at start, or 1 s for bags with /clock).
  int64_t stamp_origin_ns = 0;
  /// Overrides the profile's effects entirely when set (start from sensorProfile(profile)).
  std::optional<SensorEffects> effects;
  DetectorErrorModel detector;  ///< the simulated detector defaults of docs/conventions.md
  /// Cameras moved during the run (CameraBump); a camera with several takes the latest due.
  /// Empty: every frame as without the option.
  std::vector<CameraBump> bumps;
  /// Every pipe of the scene takes this pipe catalogue entry's geometry (loadScenario; the
  /// catalogue beside config/scenes/); "": the scene's own.
  std::string pipe_type;
};

/// One capture of the schedule.
struct Capture {
  double t = 0.0;            ///< [s] capture time (simulation time)
  size_t camera = 0;         ///< camera index
  uint64_t frame_index = 0;  ///< per-camera frame counter (k-th period of that camera)
};

class RigSimulator {
 public:
  /// Throws InputError for an unknown profile or sensor type, or an empty rig.
  RigSimulator(const RigCalibration& rig, const SceneConfig& scene, const SimulatorOptions& opt);
  ~RigSimulator();

  size_t numCameras() const { return cams_.size(); }
  const std::string& cameraName(size_t i) const;
  const std::string& worldFrame() const { return world_frame_; }

  /// world -> <cam>_link as TF should publish it (the true one plus the injected calibration
  /// error in the field profile).
  Eigen::Isometry3d publishedT_world_link(size_t i) const;
  /// world -> <cam>_link used for rendering (before any SimulatorOptions::bumps).
  Eigen::Isometry3d trueT_world_link(size_t i) const;
  /// T_link_depth: <cam>_rgb_optical_frame -> <cam>_ir_optical_frame as a TF (parent -> child):
  /// p_link = T_link_depth * p_depth. Translation ~ (-0.0515, 0, -0.001) m for a Kinect v2.
  Eigen::Isometry3d T_link_depth(size_t i) const;
  /// Colour and depth CameraInfos of camera i (frame ids set, full images).
  const CameraInfoData& colorInfo(size_t i) const;
  const CameraInfoData& depthInfo(size_t i) const;
  /// Per-camera residual depth offset added to every depth [m] (0 when off).
  double depthOffset(size_t i) const;
  /// Per-camera depth scale (depth x this before the offset; 1 when the effect is off).
  double depthScale(size_t i) const;
  /// The depth offset [m] a depth calibration of camera i at the rig's range finds: depthOffset
  /// plus the scaled weak-return brightness bias, sim::brightnessBias(effects(), 0), which every
  /// surface at 5-7 m reads (constant there: their amplitudes lie below its floor; about
  /// +28.5 mm in kinect_v2_uncalibrated, whose brightness_bias_reference is 0). The camera reads
  /// z_meas = depthScale * z_true + effectiveDepthOffset there.
  double effectiveDepthOffset(size_t i) const;
  /// The rig file of the truth: world -> <cam>_link as rendered (trueT_world_link), each
  /// camera's sensor, depthScale and effectiveDepthOffset (core rig_calibration.hpp).
  RigCalibration trueRig() const;

  /// Capture times [s] in [t0, t1) of all cameras, sorted: (time, camera).
  std::vector<std::pair<double, size_t>> captureSchedule(double t0, double t1) const;
  /// The same with each capture's frame index (pass it to render()).
  std::vector<Capture> captures(double t0, double t1) const;
  /// Capture time [s] of camera i's frame k.
  double captureTime(size_t i, uint64_t k) const;

  struct Frame {
    SensorFrameData sensor_frame;  ///< stamped stamp_origin_ns + t; frame ids per conventions
    std::vector<uint8_t> bgr;      ///< colour image (BGR8, row-major) when options.color
    uint32_t color_width = 0, color_height = 0;
  };
  /// Renders camera `camera` at simulation time t [s]; `frame_index` seeds the noise (use the
  /// Capture's). Boxes only when simulated_detection.
  Frame render(size_t camera, double t, uint64_t frame_index);

  struct TruthEnd {
    EndLabel label;
    std::string pipe;               ///< the pipe it belongs to
    Eigen::Isometry3d T_world_end;  ///< canonical roll (core canonicalPose)
    double nominal_od = 0;          ///< [m] tool-joint OD in the scene file
    double rendered_od = 0;         ///< [m] ...less its wear, as rendered
  };
  /// Ground-truth pipe-end poses at time t [s] (scored ends only: not distractor pipes).
  std::vector<TruthEnd> groundTruth(double t) const;
  const WorkZone& workZone() const { return scene_config_.work_zone; }

  const Scene& scene() const { return scene_; }
  const SensorEffects& effects() const { return fx_; }
  const SimulatorOptions& options() const { return opt_; }
  const SensorIntrinsics& sensor(size_t i) const;
  /// The detector (also usable on its own for tests).
  const SimulatedDetector& detector() const { return detector_; }
  /// Stamp [ns] of simulation time t.
  int64_t stampNs(double t) const;

 private:
  struct Camera;
  /// Moves the camera to its pose at time t (SimulatorOptions::bumps): its cached
  /// backgrounds are dropped when the pose changes.
  void applyBumps(Camera& cam, double t);
  void ensureBackground(Camera& cam);
  void renderDepth(Camera& cam, size_t index, const SceneSnapshot& snap, uint64_t frame_index,
                   DepthImage* out, AmplitudeImage* amplitude);
  void renderColor(Camera& cam, size_t index, const SceneSnapshot& snap, uint64_t frame_index,
                   std::vector<uint8_t>* bgr);

  std::string world_frame_;
  SceneConfig scene_config_;
  SimulatorOptions opt_;
  SensorEffects fx_;
  Scene scene_;
  std::vector<int> dynamic_objects_;
  std::vector<int> static_objects_;
  SimulatedDetector detector_;
  std::vector<std::unique_ptr<Camera>> cams_;
};

/// Loads the rig file (core loadRigCalibration) and the scene file and builds the simulator.
std::unique_ptr<RigSimulator> loadScenario(const std::string& rig_path,
                                           const std::string& scene_path,
                                           const SimulatorOptions& opt);

}  // namespace drill_pipe_pose::sim
