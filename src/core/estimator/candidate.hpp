#pragma once
// What the estimator's per-label stages share within one cycle (private to its sources): the
// cycle's read-only context, one instance's candidate fit, and the stages' timing.

#include <Eigen/Core>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/profile_registration.hpp"
#include "end_models.hpp"

namespace drill_pipe_pose {

/// Read-only inputs of one cycle's per-label stages.
struct CycleContext {
  const EstimatorConfig& config;
  const EndModels& models;
  const std::vector<CycleCamera>& cams;  ///< the cycle's valid cameras (points index them)
  int64_t stamp_ns = 0;                  ///< the cycle's latest capture stamp
  /// A full decision is planned for the box end's label in this cycle, so the pin end's
  /// periodic one waits a cycle (the two ends' decisions fall in different cycles).
  bool box_decides = false;
  /// The models of both ends of pipe type k (index into the candidates), for an other end of
  /// its own type: (*type_models)[k], null where none was built this cycle.
  const std::vector<const EndModels*>* type_models = nullptr;
};

/// One instance's fitted candidate (a cluster of one detected label's carved points).
struct Candidate {
  bool ok = false;
  EndLabel detected = EndLabel::kBoxEnd;  ///< label of the detections the points came from
  ProfileFitResult fit;                   ///< fit of the model that won (fit.label)
  std::string reason;                     ///< why not ok
  std::vector<Eigen::Vector3f> pts;       ///< [m, world] the instance's points (subsampled)
  std::vector<float> sigmas;              ///< [m] noise sigma of each point
  std::vector<uint16_t> cams;             ///< camera index of each point
  std::vector<Eigen::Vector3f> eyes;      ///< [m, world] position of the camera of each point
  double direction_margin = 0.0;  ///< score of the flipped axis direction minus the winner's
  /// The position along the axis comes from the scan (locked in the refinement): the fit's
  /// covariance does not describe it.
  bool axial_from_scan = false;
  /// With axial_from_scan: the rise of the scan's score 1 cm either side of its best position
  /// (the smaller one), in score units (EstimatorConfig::FreeSpace).
  double axial_contrast = 0.0;
  /// The model and direction came from the end's track (no hypothesis decision this cycle).
  bool tracked = false;
  /// The level support found at the decision (or the track's): the points below
  /// support_z + profile_fit.support_clearance are left out of the pose refinement.
  bool has_support = false;
  float support_z = 0.0f;  ///< [m] world height of the support
  /// The points the pose refinement used (of pts): the fit's inliers are counted among them.
  size_t fit_points = 0;
  /// The fit was rejected for its residual or its inliers (a model of another size fits so).
  bool poor_fit = false;
};

/// Time [ms] one label's stages spent, summed over its instances.
struct LabelTiming {
  double segmentation_ms = 0.0, registration_ms = 0.0;
  double edges_ms = 0.0;  ///< of registration_ms: the scan along the axis on the edge pixels
};

using Clock = std::chrono::steady_clock;
inline double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace drill_pipe_pose
