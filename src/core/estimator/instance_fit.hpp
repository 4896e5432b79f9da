#pragma once
// Stages "axis fit", "hypotheses and decision" and "refinement" for one instance of a label: its
// points -> a candidate pose with the model that fits, or the reason there is none (private to
// the estimator's sources).

#include <Eigen/Core>
#include <vector>

#include "candidate.hpp"
#include "drill_pipe_pose/core/estimator/axis_fit.hpp"
#include "drill_pipe_pose/core/estimator/track.hpp"

namespace drill_pipe_pose {

/// Fits one instance (one cluster of label `label`'s carved points). Holds the instance's point
/// subsamples for the life of one fit().
class InstanceFitter {
 public:
  /// `points` are subsampled to profile_fit.max_points (deterministic stride).
  InstanceFitter(const CycleContext& ctx, int label, const std::vector<CloudPoint>& points);

  /// The instance's candidate: when `follow_track` and the label's `track` continues into this
  /// cycle, its tracked fit (the track's model and direction, refined from its prediction);
  /// otherwise - or when the fit leaves the track's gates - a full decision (axis fit, both
  /// models in both directions, refinement of the winner). Then the acceptance gates. Adds its
  /// time to `timing`.
  Candidate fit(const Track& track, bool follow_track, LabelTiming* timing);

 private:
  using Points = std::vector<Eigen::Vector3f>;
  /// Symmetric score of model m at (o, z) in "unexplained measurement" units: each point's
  /// truncated squared distance / truncation^2 (scaled by n_scale), plus pixel_weight per depth
  /// pixel on which the model claims a surface that the camera saw through.
  double poseScore(int m, const Points& P, const Points* E, double n_scale,
                   const Eigen::Vector3d& o, const Eigen::Vector3d& z) const;
  /// Scan of the position along the axis (f->origin + delta f->z) minimising poseScore: a coarse
  /// pass over +-range [m] at `step`, then +-step at step / 2 (or `fine` when > 0). With
  /// `coarse_points_only` the coarse pass ranks by the points alone; with `points_only` the
  /// seen-through pixels are not counted at all. Moves f->origin; returns the best score.
  double axialScan(int m, const Points& P, const Points* E, double n_scale, ProfileFitResult* f,
                   double range, double step, double fine, bool coarse_points_only,
                   bool points_only = false) const;
  /// The tracked fit: the track's model and axis from its prediction `pred`, position scanned,
  /// refined; still tracked when it stays within tracking.max_angle / max_offset.
  void followTrack(const Track& track, const Eigen::Vector3d& pred);
  /// The axis of a decision: the track's (a periodic decision), or the support plane removed and
  /// the cylinder axis fitted. False with cd_.reason set when there is none.
  bool decisionAxis(bool periodic, const Track& track, const Eigen::Vector3d& pred,
                    AxisFitResult* axis);
  /// Both models x both axis directions on `axis`, each at its best position; the winner (the
  /// detected label's model unless the other is better by profile_fit.label_margin) refined.
  void decideHypotheses(const AxisFitResult& axis);
  /// The winner's fine position along the axis, then the 5-DoF refinement with projective
  /// correspondences (free and locked along the axis; the better is polished on every point).
  bool refineWinner(int win);
  /// The position along the axis from the depth pixels around the end (edgeNegLogLikelihood):
  /// f moved along its axis to the best of a scan over edges.scan_range (6 mm steps, then 3 and 1 mm).
  void edgeScan(int m, ProfileFitResult* f) const;
  /// With the position along the axis from the scan: the fit's axial variance replaced by the
  /// scan's (from cd_.axial_contrast), uncorrelated with the other parameters.
  void scanAxialCovariance(ProfileFitResult* fit) const;
  /// The acceptance gates: direction margin, residual and inliers, axial contrast, reported
  /// uncertainty. Sets cd_.ok, or cd_.reason.
  void gate();

  const CycleContext& ctx_;
  const EstimatorConfig& config_;
  const int label_;
  Candidate cd_;
  /// The coarse subsample (every coarse_stride_-th of cd_.pts).
  size_t coarse_stride_ = 1;
  Points coarse_pts_, coarse_eyes_;
  std::vector<float> coarse_sig_;
  Points scan_pts_;       ///< points of the decision scans
  double n_scale_ = 0.0;  ///< the scans' points scaled to this count (cd_.pts.size())
  /// [m] how far the end moves (its track's mean speed) between the cycle's earliest and latest
  /// camera frame; 0 without a fit within tracking.max_gap.
  double motion_ = 0.0;
  LabelTiming* timing_ = nullptr;
};

}  // namespace drill_pipe_pose
