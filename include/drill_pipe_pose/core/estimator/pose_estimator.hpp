#pragma once
// The ROS-free pipe-end pose estimator: N cameras' SensorFrames -> per-end 6-DoF poses
// with covariance. The node and bench_estimator call it through the core CycleRunner
// (cycle_runner.hpp), which assembles CameraInput from frames and transforms; tests call it
// directly.

#include <Eigen/Geometry>
#include <array>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/estimator/drift_watch.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"

namespace drill_pipe_pose {

/// One camera's contribution to a cycle.
struct CameraInput {
  /// Depth (maybe cropped: depth_info.roi), both CameraInfos, boxes in colour-image pixels.
  SensorFrameData frame;
  /// Depth optical frame -> world at the frame's stamp (tf2 in the node).
  Eigen::Isometry3d T_world_depth = Eigen::Isometry3d::Identity();
  /// Colour optical <- depth optical (p_color = T_color_depth * p_depth), from TF.
  Eigen::Isometry3d T_color_depth = Eigen::Isometry3d::Identity();
  /// The camera's depth calibration (rig file: depth_offset, depth_scale): every depth the
  /// estimator reads is corrected by it. Default: none.
  DepthCorrection depth_correction;
};

/// The estimate of one pipe end in one cycle.
struct EndEstimate {
  EndLabel label = EndLabel::kBoxEnd;
  bool valid = false;
  std::string reason;  ///< why not valid (empty when valid)
  /// Pipe-end frame (docs/conventions.md) in the world, canonical roll.
  Eigen::Isometry3d T_world_end = Eigen::Isometry3d::Identity();
  /// 6x6 covariance of (x, y, z [m], rotation about world x, y, z [rad]) as in
  /// geometry_msgs/PoseWithCovariance; the variance about the pipe axis (roll) is large.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  double residual = 0.0;             ///< [m] RMS distance of the inlier points to the model surface
  size_t points = 0;                 ///< points used in the final fit (inliers)
  std::vector<std::string> cameras;  ///< cameras that contributed inlier points
  /// True when the detections said the other label and the geometry overruled them.
  bool label_corrected = false;
  /// The model and the axis direction came from this end's track (EstimatorConfig::Tracking):
  /// no full decision this cycle.
  bool tracked = false;
  /// The end's pipe type (pipe_type.hpp): the candidate whose model it is fitted with, every
  /// candidate's name and probability (EstimatorConfig::candidates' order), and what was
  /// measured: the tool-joint OD [m] averaged on its track, its spread [m] and the number of
  /// measurements (0: none yet); the tube's OD [m] where the model's tube was seen.
  std::string type;
  /// Instance id of the end: kept while its track continues (typing's evidence with it), never
  /// reused by this estimator; 0 without a track.
  uint32_t instance_id = 0;
  std::vector<std::string> type_names;
  std::vector<double> type_probabilities;
  double measured_od = 0.0;
  double measured_od_spread = 0.0;
  size_t type_measurements = 0;
  double measured_tube_od = 0.0;
  size_t tube_measurements = 0;
  /// The joint OD [m] of the end's radius searches (refitted with models of other radii; what
  /// decides its joint OD) averaged on its track (SearchedRadii: robustly), the searches that
  /// mean is over, every search on the track (0: none yet), and the latest search's OD [m].
  double searched_od = 0.0;
  size_t searches_counted = 0;
  size_t searches = 0;
  double last_search_od = 0.0;
};

struct CycleTiming {
  double cutout_ms = 0, fusion_ms = 0, segmentation_ms = 0, registration_ms = 0, total_ms = 0;
  double edges_ms = 0;  ///< of registration_ms: the scans along the axis on the edge pixels
};

struct CycleResult {
  std::array<EndEstimate, kNumEnds> ends;  ///< [0] box_end, [1] pin_end
  /// Every other end in the work zone that a detection boxes and the fit accepts (several pipes
  /// at once), each with its own instance id; valid, no temporal filter. `ends` is the primary
  /// pair (the end each label's track follows).
  std::vector<EndEstimate> others;
  CycleTiming timing;
  std::vector<std::string> camera_errors;  ///< bad inputs, one line per skipped camera
  std::vector<std::string> cameras_used;   ///< cameras whose frames entered this cycle
  /// The drift watch after this cycle (EstimatorConfig::Drift): every camera it has seen, with
  /// its running disagreement with the fused fit, its flag, and whether this cycle's fit left
  /// its points out. Empty when drift.enabled is false (or with thesis_baseline).
  std::vector<CameraDriftStatus> drift;
  /// Per detected label ([0] box_end, [1] pin_end): its candidate ends in the work zone (the
  /// clusters of its carved points; EstimatorConfig::Instances).
  std::array<uint32_t, kNumEnds> instances{{0, 0}};
  /// Debug clouds [m, world]: all fused (carved) points, and the points of each end's final fit.
  std::vector<Eigen::Vector3f> fused;
  std::array<std::vector<Eigen::Vector3f>, kNumEnds> segmented;
  const EndEstimate& end(EndLabel l) const { return ends[static_cast<int>(l)]; }
};

/// The pipeline. Not thread-safe (one instance per thread). Keeps state across cycles in one
/// place (per label: the track, the instance memory, the label-flip count; per end: the temporal
/// filter; the drift watch's per-camera estimates; the thesis_baseline's layers and model poses);
/// reset() clears all of it.
class PoseEstimator {
 public:
  /// Validates the configuration (throws InputError naming the key) and builds the models.
  explicit PoseEstimator(const EstimatorConfig& config);
  ~PoseEstimator();
  PoseEstimator(const PoseEstimator&) = delete;
  PoseEstimator& operator=(const PoseEstimator&) = delete;

  /// One cycle. A camera with bad input (size/intrinsics/roi/encoding) is skipped and named in
  /// camera_errors; the others go on. Never throws on bad data.
  CycleResult process(const std::vector<CameraInput>& cameras);

  /// Forgets every state kept across cycles (as a newly built estimator).
  void reset();

  const EstimatorConfig& config() const { return config_; }

 private:
  struct Impl;
  EstimatorConfig config_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace drill_pipe_pose
