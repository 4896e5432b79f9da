#pragma once
// The RGB-D sensor model: intrinsics and colour/depth extrinsics of one sensor type (from
// config/sensors/<sensor>.yaml), and the switchable sensor effects of the three profiles
// (docs/conventions.md, "Sensor profiles"). Every default cites its source.

#include <Eigen/Geometry>
#include <string>

#include "drill_pipe_pose/core/camera_model.hpp"

namespace drill_pipe_pose::sim {

/// Geometry of one RGB-D sensor type.
struct SensorIntrinsics {
  std::string name = "kinect_v2";
  PinholeCamera depth;  ///< rectified depth (IR) camera, full image
  PinholeCamera color;  ///< rectified colour camera, full image
  /// T_color_depth = T_link_depth: maps points of <cam>_ir_optical_frame into
  /// <cam>_rgb_optical_frame (p_color = T_color_depth * p_depth). As a TF it is the transform
  /// parent <cam>_rgb_optical_frame -> child <cam>_ir_optical_frame; its translation is the IR
  /// camera's origin in the colour optical frame: about (-0.0515, 0, -0.001) m for a Kinect v2
  /// (iai_kinect2 calib_pose.yaml), i.e. the IR camera sits 5 cm to the colour camera's left.
  Eigen::Isometry3d T_color_depth = Eigen::Isometry3d::Identity();
  double frame_rate_hz = 30.0;  ///< [Hz] nominal frame rate

  /// Built-in Kinect v2 values (identical to config/sensors/kinect_v2.yaml).
  static SensorIntrinsics kinectV2();
};

/// Loads config/sensors/<sensor>.yaml; InputError names the file and the key.
SensorIntrinsics loadSensorIntrinsics(const std::string& path);

/// Every sensor effect, switchable on its own. Defaults = the `kinect_v2_calibrated` profile.
struct SensorEffects {
  // --- depth noise
  /// Axial noise sigma_z(z, theta) of Fankhauser, Bloesch, Rodriguez, Kaestner, Hutter,
  /// Siegwart, "Kinect v2 for mobile robot navigation: evaluation and modeling", ICAR 2015:
  /// sigma_z[mm] = 1.5 - 0.5 z + 0.3 z^2 + 0.1 z^1.5 theta^2 / (pi/2 - theta)^2 (z [m]).
  bool axial_noise = true;
  double axial_noise_scale = 1.0;  ///< multiplies sigma_z (1 = the paper's fit)
  /// Lateral noise of the same paper: sigma_L[px] = 0.8 + 0.035 theta / (pi/2 - theta),
  /// realised by reading each output pixel from a randomly shifted source pixel.
  bool lateral_noise = true;
  double max_incidence_deg = 84.0;  ///< incidence angles are clamped here in the noise models
  /// 1 mm quantisation: 16UC1 millimetre output as kinect2_bridge publishes (REP 118). Off:
  /// 32FC1 metres, unquantised.
  bool quantisation = true;
  // --- range
  /// [m] Kinect v2 spec minimum 0.5 m (Microsoft Kinect for Windows v2 data sheet).
  double min_range = 0.5;
  /// [m] kinect2_bridge's `max_depth` parameter default is 12 m (iai_kinect2
  /// kinect2_bridge.launch); the official range is 4.5 m but the rig runs at 5.5-7 m.
  double max_range = 12.0;
  // --- missing data
  /// Dropout where the returned amplitude a = reflectivity cos(theta) / z^2 [1/m^2] is low (ToF
  /// amplitude threshold, libfreenect2 DepthPacketProcessor `ab_threshold`; dark/specular
  /// surfaces drop out, Fankhauser et al. 2015 Sec. IV, Sarbolandi et al. CVIU 2015). Linear ramp
  /// of dropout probability from 1 at `dropout_amplitude_low` to 0 at `dropout_amplitude_high`.
  /// Values are this project's calibration: yellow paint (0.6) is valid beyond 8 m head-on,
  /// bare dark steel (0.12) loses about a third of its pixels head-on at 6.5 m, more at the sides.
  bool dropout = true;
  double dropout_amplitude_low = 0.0015;   ///< [1/m^2]
  double dropout_amplitude_high = 0.0035;  ///< [1/m^2]
  /// Flying (mixed) pixels at depth discontinuities: a ToF pixel straddling an edge mixes the
  /// two returns (Fankhauser et al. 2015 Sec. IV-D; Sarbolandi et al. 2015). libfreenect2's
  /// edge-aware filter removes many of them, hence a probability below 1.
  bool flying_pixels = true;
  double flying_probability = 0.35;  ///< per edge pixel
  double flying_jump = 0.05;         ///< [m] neighbour depth difference that makes an edge
  // --- systematic errors
  /// Per-camera residual depth offset, uniform in +-max_depth_offset, seeded per camera.
  /// Calibrated: <= 5 mm, field: <= 10 mm (what a calibration leaves); the uncalibrated Kinect v2
  /// offset is several cm (Lachat et al., ISPRS 2015; Fankhauser et al. 2015).
  bool depth_offset = true;
  double max_depth_offset = 0.005;  ///< [m]
  /// Interference bursts between overlapping ToF cameras (Sarbolandi et al., CVIU 2015, Sec. 7:
  /// multi-device interference shows as sporadic noisy/invalid regions). Per camera frame, with
  /// `interference_probability`, a horizontal band of `interference_band_fraction` of the rows
  /// gets extra noise `interference_sigma` and dropout `interference_dropout`.
  bool interference = false;
  double interference_probability = 0.03;
  double interference_band_fraction = 0.25;
  double interference_sigma = 0.03;  ///< [m]
  double interference_dropout = 0.3;
  // --- timing
  /// Unsynchronised cameras: each camera its own phase, uniform in one frame period, plus a
  /// per-frame capture jitter (Kinect v2 units are not hardware-synchronisable; USB3 frame
  /// timing jitter of ~1 ms, libfreenect2 timestamps).
  bool unsynchronised = true;
  double clock_jitter_sigma = 0.001;  ///< [s]
  // --- calibration
  /// Calibration error injection: the PUBLISHED world -> <cam>_link differs from the true one by
  /// a translation of `calib_translation_error` and a rotation of `calib_rotation_error_deg`
  /// about seeded random directions (the kinect_v2_field profile).
  bool calibration_error = false;
  double calib_translation_error = 0.005;  ///< [m]
  double calib_rotation_error_deg = 0.2;   ///< [deg]
  // --- scene realism
  /// Rendered tool joints differ from the nominal model as worn joints do:
  /// tool-joint OD reduced by up to max_od_wear, tong length by up to max_tong_wear, seeded per
  /// pipe; mud patches of lower reflectivity.
  bool wear = true;
  double max_od_wear = 0.002;    ///< [m] on the diameter
  double max_tong_wear = 0.020;  ///< [m]
  bool mud = true;
  int min_mud_patches = 1, max_mud_patches = 4;  ///< per tool joint
  // --- colour image
  bool color_noise = true;
  double color_noise_sigma = 3.0;  ///< [DN] Gaussian per channel (typical CMOS at indoor light)
};

/// The named profiles (docs/conventions.md): "ideal", "kinect_v2_calibrated", "kinect_v2_field".
/// Throws InputError for any other name.
SensorEffects sensorProfile(const std::string& name);

/// Switches one effect of `effects` off by its field name (axial_noise, lateral_noise,
/// quantisation, dropout, flying_pixels, depth_offset, interference, unsynchronised,
/// calibration_error, wear, mud, color_noise): to see what each costs the estimator. Throws
/// InputError naming the valid names for an unknown one.
void switchOffEffect(SensorEffects* effects, const std::string& name);

/// Axial noise standard deviation [m] at depth z [m] and incidence angle theta [rad]
/// (Fankhauser et al. 2015, see SensorEffects::axial_noise). theta is clamped to
/// max_incidence_rad.
double axialNoiseSigma(double z, double theta, double max_incidence_rad = 84.0 * M_PI / 180.0);

/// Lateral noise standard deviation [px] at incidence angle theta [rad] (Fankhauser et al. 2015).
double lateralNoiseSigmaPx(double theta, double max_incidence_rad = 84.0 * M_PI / 180.0);

}  // namespace drill_pipe_pose::sim
