#pragma once
// The RGB-D sensor model: intrinsics and colour/depth extrinsics of one sensor type (from
// config/sensors/<sensor>.yaml), and the switchable sensor effects of the three profiles
// (docs/conventions.md, "Sensor profiles"). Every default cites its source.

#include <Eigen/Geometry>
#include <string>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"

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
  /// Lateral noise of the same paper: sigma_L[px] = s0 + 0.035 theta / (pi/2 - theta),
  /// realised by reading an output pixel from a randomly shifted source pixel, at depth edges
  /// only (a 4-neighbour differs by more than flying_jump): the paper measured it as the jitter
  /// of an edge, and on smooth tilted surfaces a real Kinect v2 shows no such extra spread (the
  /// bright squares of a chessboard at 0.5-1.5 m and 4-33 deg: docs/sensor_check.md).
  bool lateral_noise = true;
  /// [px] s0, the sigma head-on. The paper's 0.8 px made a board's silhouette 1.1-1.5 times as
  /// ragged as a real Kinect v2's behind kinect2_bridge; fitted on that silhouette together with
  /// the edge pixels below (`scripts/sensor_check DATA --fit-edges`, the iai_kinect2 chessboard
  /// recording at 0.5-1.5 m).
  double lateral_noise_px = 0.3;
  bool lateral_noise_at_edges_only = true;  ///< false: every pixel (the model before the fit)
  /// The returned amplitude falls with the range (the ray's length); false: with the depth z
  /// (the model before the fit).
  bool amplitude_by_range = true;
  double max_incidence_deg = 84.0;  ///< incidence angles are clamped here in the noise models
  // --- effects of the returned amplitude a = reflectivity cos(theta) / range^2 [1/m^2],
  // fitted to a real Kinect v2 imaging a chessboard at 0.5-1.5 m (`scripts/sensor_check DATA
  // --fit`, docs/sensor_check.md). The fit is in the IR image's digital numbers (DN); the
  // simulator's amplitude is tied to them by white paper = reflectivity 0.8: A_DN = 40260 a.
  /// Noise of a weak return: sigma = max(sigma_z, sqrt(floor^2 + (C / a)^2)). Fitted: the noise
  /// of the dark squares grows as 1/A (free power law: A^-1.01), the bright squares' spread is
  /// the floor. Beyond the data (a < 0.02, i.e. any surface at 5-7 m) the 1/a term is
  /// extrapolated; sigma_z (the paper's fit, measured on its own target) stays the lower bound,
  /// so it only adds where a surface is darker than that target would be at its range.
  bool amplitude_noise = true;
  /// [m] the bright squares' spread, 1.49 mm, less quantisation
  double amplitude_noise_floor = kinect_v2::AmplitudeModel{}.noise_floor;
  /// [m m^-2] C: 5622 DN mm / 40260
  double amplitude_noise_coeff = kinect_v2::AmplitudeModel{}.noise_coeff;
  /// The other reading beyond the data: sigma = sqrt(sigma_z^2 + (C / a)^2), the weak-return
  /// term added to the range law (which then counts range twice); scripts/bench compares both.
  bool amplitude_noise_additive = false;
  /// Spatially correlated depth noise: the axial noise of each pixel is a field of normal
  /// numbers smoothed by the separable kernel [w, 1, w] (renormalised), w chosen so that
  /// horizontally or vertically adjacent pixels correlate by noise_correlation. A real Kinect
  /// v2 behind kinect2_bridge (bilateral and edge-aware filters on by default) shows 0.45-0.56
  /// on a chessboard with each square's mean removed, 0.59 on the difference of two frames.
  bool correlated_noise = true;
  double noise_correlation = 0.62;  ///< chosen so that the sensor check's corr sq matches (<= 0.7)
  /// Depth bias of a weak return: + B max(a, brightness_bias_min_amplitude)^-p (farther), less
  /// B brightness_bias_reference^-p (what a calibration on a target of that amplitude removed;
  /// reference 0: nothing removed). Fitted: dark minus bright squares = B (A_dark^-p -
  /// A_bright^-p), p = 4 (least rms of the powers 0.5-4: the bias stays near 0 above ~2000 DN
  /// and rises steeply below ~1000 DN), B = 1.06e13 DN^4 mm (rms 6.5 mm over 23 frames). Held
  /// constant below the lowest fitted amplitude (781 DN, 28.5 mm there: not extrapolated), so at
  /// 5-7 m every surface reads about the same bias, which a depth-offset calibration at the
  /// rig's range removes (the calibrated profiles' reference).
  bool brightness_bias = true;
  /// [m (1/m^2)^p] B: 1.06e13 DN^4 mm / 40260^4
  double brightness_bias_coeff = kinect_v2::AmplitudeModel{}.bias_coeff;
  double brightness_bias_power = kinect_v2::AmplitudeModel{}.bias_power;  ///< p
  /// [1/m^2] 781 DN / 40260
  double brightness_bias_min_amplitude = kinect_v2::AmplitudeModel{}.bias_min_amplitude;
  /// [1/m^2] calibrated at the rig's range (a target there returns less than this)
  double brightness_bias_reference = kinect_v2::AmplitudeModel{}.bias_min_amplitude;
  /// Saturation of strong returns: invalid with a probability rising linearly from 0 at
  /// saturation_amplitude_low to 1 at saturation_amplitude_high. Fitted on the bright squares'
  /// invalid fraction (all gone at 0.55-0.63 m, none beyond 0.76 m): 56000-76000 DN.
  bool saturation = true;
  double saturation_amplitude_low = 1.39;   ///< [1/m^2] 56000 DN / 40260
  double saturation_amplitude_high = 1.89;  ///< [1/m^2] 76000 DN / 40260
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
  /// An edge pixel (a 4-neighbour differs by more than flying_jump) is invalid with
  /// edge_invalid_probability (the driver's edge-aware filter), else mixed with
  /// flying_probability: its depth moves towards the neighbour across the jump by a fraction
  /// drawn uniformly between flying_weight_min and flying_weight_max. The two probabilities
  /// share one draw: where they sum past 1, the mixed pixels get what the invalid ones leave.
  /// Fitted (`scripts/sensor_check DATA --fit-edges`, the board's silhouette 0.2 m in front of
  /// the chair behind it, 0.5-1.5 m): every edge pixel is touched, half invalid, half mixed by
  /// an area share of 0.1-1 weighted by amplitude. Before the fit: none invalid, 35 % mixed by
  /// a plain fraction of 0-1 (literature), which gave 0.4 mixed and no invalid pixels per
  /// crossing of the silhouette against 0.8-1.0 and 1.0-1.2 real.
  bool flying_pixels = true;
  double flying_probability = 0.5;  ///< per edge pixel
  double edge_invalid_probability = 0.5;
  double flying_weight_min = 0.1;
  double flying_weight_max = 1.0;
  /// true: the drawn fraction is the neighbour's share of the pixel's footprint, and the depth
  /// moves by the neighbour's share of the two returns' amplitudes (a mixed ToF pixel reads
  /// the amplitude-weighted mean of its two returns, so it stays near the brighter one);
  /// false: the depth moves by the drawn fraction itself.
  bool flying_amplitude_weighted = true;
  double flying_jump = 0.05;         ///< [m] neighbour depth difference that makes an edge
  // --- systematic errors
  /// Per-camera residual depth offset, uniform in +-max_depth_offset, seeded per camera.
  /// Calibrated: <= 5 mm, field: <= 10 mm (what a calibration leaves); the uncalibrated Kinect v2
  /// offset is several cm (Lachat et al., ISPRS 2015; Fankhauser et al. 2015).
  bool depth_offset = true;
  double max_depth_offset = 0.005;  ///< [m]
  /// Per-camera depth scale error: depth x (1 + s), s uniform in +-max_depth_scale_error, seeded
  /// per camera. The real device read -1.9 % (depth against the chessboard plane from PnP, with
  /// the IR intrinsics fitted jointly on the same frames: -18.7 mm/m). Off when calibrated.
  bool depth_scale = false;
  double max_depth_scale_error = 0.019;
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

/// The named profiles (docs/conventions.md): "ideal", "kinect_v2_calibrated", "kinect_v2_field",
/// "kinect_v2_uncalibrated". Throws InputError for any other name.
SensorEffects sensorProfile(const std::string& name);

/// Switches one effect of `effects` off by its field name (axial_noise, lateral_noise,
/// amplitude_noise, correlated_noise, brightness_bias, saturation, quantisation, dropout,
/// flying_pixels, depth_offset, depth_scale, interference, unsynchronised, calibration_error,
/// wear, mud, color_noise): to see what each costs the estimator. Throws
/// InputError naming the valid names for an unknown one.
void switchOffEffect(SensorEffects* effects, const std::string& name);

/// Sets one numeric parameter of `effects` by its field name (lateral_noise_px,
/// flying_probability, edge_invalid_probability, flying_weight_min, flying_weight_max,
/// flying_jump, flying_amplitude_weighted (0 or 1)): for fitting the edge model and for benching
/// a model against another. Throws InputError naming the valid names for an unknown one, or for
/// a value out of its range.
void setEffectParameter(SensorEffects* effects, const std::string& name, double value);

/// Parses "NAME=VALUE" and applies it with setEffectParameter; InputError names the text.
void setEffectParameter(SensorEffects* effects, const std::string& assignment);

/// The sensor model as it was before its fit to real Kinect v2 frames (white axial noise, no
/// amplitude-dependent effects, lateral noise on every pixel): for before/after comparisons. Its
/// frames are bit-identical to that model's for the same seed.
void useModelBeforeFit(SensorEffects* effects);

/// The edge model as it was before its fit to a real board's silhouette (lateral noise 0.8 px
/// head-on, 35 % of edge pixels mixed by a plain fraction of the jump, none invalid): for
/// before/after comparisons, and for the regression tests whose figures were set on it.
void useEdgeModelBeforeRefit(SensorEffects* effects);

/// Axial noise standard deviation [m] at depth z [m] and incidence angle theta [rad]
/// (Fankhauser et al. 2015, see SensorEffects::axial_noise). theta is clamped to
/// max_incidence_rad.
double axialNoiseSigma(double z, double theta, double max_incidence_rad = 84.0 * M_PI / 180.0);

/// Lateral noise standard deviation [px] at incidence angle theta [rad] (Fankhauser et al. 2015).
/// `head_on_px` is the sigma at theta = 0 (SensorEffects::lateral_noise_px).
double lateralNoiseSigmaPx(double theta, double max_incidence_rad = 84.0 * M_PI / 180.0,
                           double head_on_px = SensorEffects{}.lateral_noise_px);

}  // namespace drill_pipe_pose::sim
