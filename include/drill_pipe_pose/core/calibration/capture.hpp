#pragma once
// One frame of one camera -> one Observation: the target's corners in the grey image and a
// sample of the depth pixels on the target. ROS-free; the simulator's capture tool and the
// bag-reading tool share it.

#include <opencv2/core.hpp>
#include <string>

#include "drill_pipe_pose/core/calibration/observations.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"

namespace drill_pipe_pose::calibration {

struct CaptureOptions {
  /// At most this many depth samples, spread evenly over the target (a regular pixel grid).
  /// 600: ~1 sample per 4 x 4 depth pixels of a 1.2 m board at 5-7 m, plenty for a plane's
  /// offset while keeping the observations file small.
  int max_depth_samples = 600;
  /// Fewest corners for an observation (and for the pose that places the depth samples).
  int min_corners = 6;
  /// Depth samples only where the print is white within `edge_margin`, each with its read
  /// depth corrected for the weak-return bias and given its own noise, both from the sensor
  /// model (core/kinect_noise.hpp) at the print's amplitude a = r cos(incidence) / range^2. A
  /// Kinect v2 reads a strong return nearer than a weak one (docs/sensor_check.md): at 5-6.5 m
  /// white paper reads 11-25 mm nearer than the dark steel of a tool joint, whose bias is held
  /// at its floor there; the correction makes the white print read like the steel, so the offset
  /// found is the one the estimator needs. The black print is left out: its return is so weak at
  /// these ranges that most of its pixels drop out and the rest scatter by ~0.1 m. On the simulator's calibration scene (seed
  /// 71), depth from the whole board without the model put the offsets 10-19 mm off and pulled
  /// the extrinsics by 5-11 mm.
  bool weak_return_model = true;
  /// IR reflectivity of the white print: 0.8, white paper, the unit of the sensor model's
  /// amplitude (scripts/sensor_check --fit).
  double light_reflectivity = 0.8;
  /// [m] 10 mm: half a depth pixel at 7 m, so that a sample's pixel centre sees one print.
  double edge_margin = 0.01;
  /// [DN per 1/m^2] the IR image's digital numbers per unit of amplitude (a Kinect v2's:
  /// kinect_v2::kDnPerAmplitude; the estimator's noise/amplitude_scale).
  double amplitude_scale = kinect_v2::kDnPerAmplitude;
};

/// The observation of `camera` at `placement` (empty `corners` when the target was not found).
/// Depth samples (only when `camera.depth_intrinsics` and `depth` has pixels): the depth pixels
/// inside the target's outline shrunk by half a square (on its white print; with
/// `weak_return_model`, bias-corrected and with their own noise), placed by a cv::solvePnP pose of the detected corners and camera.T_camera_depth;
/// zero / invalid depths dropped.
/// Amplitude samples (only when `amplitude` is given, on the depth image's grid): the depth pixels
/// inside the same outline on either print (at least `edge_margin` from the other), as read,
/// with their IR amplitude / options.amplitude_scale; pixels of amplitude 0 dropped; thinned to
/// at most max_depth_samples.
Observation extractObservation(const TargetGeometry& target, const CameraSetup& camera,
                               const cv::Mat& gray, const DepthImage& depth, int placement,
                               double stamp, const CaptureOptions& options = {},
                               const AmplitudeImage* amplitude = nullptr);

}  // namespace drill_pipe_pose::calibration
