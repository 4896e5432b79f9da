#pragma once
// The track of one detected label across cycles (EstimatorConfig::Tracking): its last valid fit,
// the velocity of its origin, and the questions every stage asks of it ("does it continue into
// this cycle?", "where does it predict the end?").

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>

#include "drill_pipe_pose/core/conventions.hpp"

namespace drill_pipe_pose {

/// What a cycle's accepted fit of a label hands to its track (Track::follow).
struct TrackedFit {
  EndLabel model = EndLabel::kBoxEnd;  ///< the model that fitted
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< [m] world, pipe-end origin
  Eigen::Vector3d z = Eigen::Vector3d::UnitZ();      ///< unit pipe-end axis in the world
  bool tracked = false;  ///< the fit followed the track (no full decision this cycle)
  double direction_margin = 0.0;  ///< score of the flipped axis minus the winner's (decisions)
  bool has_support = false;       ///< a level support under the end (see Candidate)
  float support_z = 0.0f;         ///< [m] world height of that support
};

/// The last valid fit of the points of one detected label.
struct Track {
  bool valid = false;  ///< the label's last cycle gave a valid fit
  EndLabel model = EndLabel::kBoxEnd;  ///< the model that fitted
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< [m] world
  Eigen::Vector3d z = Eigen::Vector3d::UnitZ();      ///< unit axis, world
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< [m/s] from the last two poses
  /// [m/s] the velocity averaged over the track's last cycles (exponentially, weight
  /// kMeanVelocityWeight per cycle): whether the end moves, rather than its last step's noise.
  Eigen::Vector3d mean_velocity = Eigen::Vector3d::Zero();
  int64_t stamp_ns = 0;  ///< capture stamp of the cycle of the last valid fit (0: never)
  int cycles = 0;  ///< cycles since the last full decision (1 = this track's decision cycle)
  double direction_margin = 0.0;  ///< of the last full decision
  bool has_support = false;  ///< the support of the last fit
  float support_z = 0.0f;    ///< [m]

  /// [s] from the last valid fit to a cycle stamped stamp_ns (negative: backwards in time).
  double gap(int64_t stamp_ns) const { return static_cast<double>(stamp_ns - this->stamp_ns) * 1e-9; }
  /// The label had a valid fit (the track may have ended since) before stamp_ns, at most
  /// max_gap [s] before it: the gap in (0, max_gap] (a fit of this very cycle is not recent).
  bool recent(int64_t stamp_ns, double max_gap) const;
  /// As recent, a fit of this very cycle included: the gap in [0, max_gap] [s].
  bool fitWithin(int64_t stamp_ns, double max_gap) const;
  /// The track is alive and continues into a cycle stamped stamp_ns: valid, and the gap in
  /// (0, max_gap] [s].
  bool continues(int64_t stamp_ns, double max_gap) const;
  /// The origin [m, world] moved on by the velocity to stamp_ns, by at most max_prediction [m].
  Eigen::Vector3d predict(int64_t stamp_ns,
                          double max_prediction = std::numeric_limits<double>::infinity()) const;
  /// The weight of each cycle's velocity in mean_velocity: about the last ten cycles. A static
  /// end's per-cycle velocity scatters by about 0.1 m/s along its axis (2 mm between 30 Hz
  /// cycles); averaged, 0.02-0.03 m/s, against the moving scene's 0.2 m/s. Not tuned.
  static constexpr double kMeanVelocityWeight = 0.1;
  /// [m/s] each cycle's velocity enters mean_velocity clamped to this: one wild fit 4 cm off and
  /// back (1.2 m/s for a cycle; thesis_vertical's box end, design seed 400) must not make a
  /// static end look moving. A pipe-handling machine's travel, well above the moving scene's
  /// 0.2 m/s; not tuned.
  static constexpr double kMeanVelocityCap = 0.5;
  /// Takes this cycle's accepted fit: the velocity follows a continuing track (same model, same
  /// axis direction, origin within max_offset [m] of the unclamped prediction), else restarts
  /// from zero.
  void follow(int64_t stamp_ns, const TrackedFit& fit, double max_gap, double max_offset);
  /// The label gave no valid fit this cycle: the track ends (its stamp and model stay, for
  /// recent()).
  void end() { valid = false; }
};

}  // namespace drill_pipe_pose
