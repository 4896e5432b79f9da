#pragma once
// Rig calibration, step 2 of 2: from the observations (observations.hpp) to every camera's pose in
// the world and its depth calibration. ROS-free; Ceres.
//
//  1. Each observation's target pose in its camera: a PnP on its corners (OpenCV, IPPE).
//  2. A first rig: the cameras and placements are reached from the anchor through shared
//     placements (breadth first); each new camera or placement takes the candidate pose that most
//     of the others agree with, so one bad observation does not start the rig wrong. A
//     chessboard's corner order is ambiguous under a half turn: an observation whose reversed
//     order agrees better with the rig is reversed (counted in the result).
//  3. One robust joint least squares over all camera poses, target poses, depth offsets (and
//     scales, and intrinsics, when asked): corner reprojection residuals plus, for every depth
//     sample, its distance from the target plane. Corners far off after the first solve are
//     dropped, and observations that disagree as a whole (a target that moved during the frame,
//     a wrongly decoded board) are rejected; then it solves again.
// Refusals (InputError naming the camera): a camera with too few usable placements, cameras not
// connected to the anchor through shared placements, a reprojection error that says the
// intrinsics do not belong to the images.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/calibration/observations.hpp"
#include "drill_pipe_pose/core/calibration/weak_return_fit.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"

namespace drill_pipe_pose::calibration {

struct SolverOptions {
  /// A camera needs corners of this many distinct placements (after rejections) to be
  /// calibrated.
  int min_placements = 4;
  /// An observation needs this many corners to enter (a PnP on fewer is unreliable).
  int min_corners = 6;
  /// [px] expected corner noise; residuals are in units of it, with a Huber loss at 3 of them.
  double corner_sigma_px = 0.3;
  /// [m] expected depth noise of one sample (a Kinect v2 at 5-7 m: 5-15 mm).
  double depth_sigma = 0.010;
  /// Estimate each depth camera's scale too (z_meas = scale z + offset); else scale = 1.
  bool estimate_depth_scale = false;
  /// Estimate every camera's fx, fy, cx, cy and distortion too.
  bool estimate_intrinsics = false;
  /// Estimate depth offsets (off: they stay 0 and depth samples are ignored).
  bool estimate_depth_offset = true;
  /// Huber losses and the outlier pass (off: plain least squares over every observation, as
  /// OpenCV's stereoCalibrate does; for comparing with such tools).
  bool robust = true;
  /// [px] a corner whose residual after the first solve exceeds this is dropped.
  double max_corner_residual_px = 2.0;
  /// [px] an observation whose corners' rms exceeds this after the first solve is rejected.
  double max_observation_rms_px = 1.0;
  /// [px] a camera whose corner rms exceeds this at the end is refused: its intrinsics do not
  /// match its images.
  double max_camera_rms_px = 1.5;
  /// Fit each camera's weak-return bias law from its amplitude samples (weak_return_fit.hpp)
  /// where the observations carry them and the solve estimates depth offsets.
  bool fit_weak_return = true;
  WeakReturnFitOptions weak_return;
};

struct CameraResult {
  std::string name;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  double depth_offset = 0.0;  ///< [m]
  double depth_scale = 1.0;
  Intrinsics intrinsics;      ///< as estimated (= the input when not estimated)
  int placements = 0;         ///< placements it saw (after rejections)
  int observations = 0;       ///< observations used (several frames of a placement each count)
  int corners = 0;            ///< corners used
  int depth_samples = 0;      ///< depth samples used
  double corner_rms_px = 0.0;
  double depth_rms = 0.0;     ///< [m] of the samples' plane distances
  /// 1-sigma of the pose from the solver's covariance: translation [m], rotation [rad].
  double sigma_translation = 0.0, sigma_rotation = 0.0;
  double sigma_depth_offset = 0.0;  ///< [m]
  /// The camera's own weak-return bias law (fitted: written to the rig file with the depth
  /// offset that goes with it; else `note` says why the sensor's law is kept).
  WeakReturnFit weak_return;
};

struct RejectedObservation {
  std::string camera;
  int placement = 0;
  std::string reason;
};

struct CalibrationResult {
  std::vector<CameraResult> cameras;             ///< in the ObservationSet's order
  std::vector<Eigen::Isometry3d> T_world_target;  ///< per placement (identity when unused)
  std::vector<RejectedObservation> rejected;
  int reversed_observations = 0;  ///< chessboard observations whose corner order was reversed
  int dropped_corners = 0;
  double corner_rms_px = 0.0;
  double seconds = 0.0;  ///< wall time of the solve
  /// The rig file (camera = <cam>_link) with depth_offset / depth_scale.
  RigCalibration rig(const ObservationSet& set) const;
};

/// Calibrates. Throws InputError for the refusals in the file comment.
CalibrationResult calibrate(const ObservationSet& set, const SolverOptions& options = {});

/// The rig after removing the one rigid transform that best aligns it to `truth` (least squares
/// over camera positions and orientations), per camera: position [m] and rotation [rad] errors;
/// plus that transform's own size (the anchoring error).
struct RigComparison {
  struct Camera {
    std::string name;
    double translation_error = 0.0, rotation_error = 0.0;  ///< after the alignment
    double raw_translation_error = 0.0, raw_rotation_error = 0.0;  ///< without it
    double depth_offset_error = 0.0;  ///< [m] estimated - true
    double depth_scale_error = 0.0;   ///< estimated - true
  };
  std::vector<Camera> cameras;
  double anchor_translation = 0.0, anchor_rotation = 0.0;  ///< the aligning transform
};
/// Throws InputError when a camera of `estimate` is not in `truth`.
RigComparison compareRigs(const RigCalibration& estimate, const RigCalibration& truth);

}  // namespace drill_pipe_pose::calibration
