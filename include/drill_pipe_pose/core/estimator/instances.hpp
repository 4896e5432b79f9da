#pragma once
// Stage "instances": a label's carved points split into candidate ends, and the choice among
// them over the cycles.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/core/estimator/profile_registration.hpp"

namespace drill_pipe_pose {

/// Clusters of `points`: connected occupied cells of a grid of edge `tolerance` [m] (cells that
/// touch, corners included, join; two points closer than `tolerance` always share a cluster,
/// points up to 2 sqrt(3) tolerance apart may). Clusters of at least `min_points`, largest
/// first, as indices into `points` (ascending within a cluster). Deterministic.
std::vector<std::vector<size_t>> euclideanClusters(const std::vector<CloudPoint>& points,
                                                   double tolerance, size_t min_points);

/// `clusters` (of `points`, as euclideanClusters gives them) with each one that a level support
/// joins split: a cluster holding a level layer (levelSupportPoints, axis_fit.plane_*: a floor or
/// catwalk under two pipes side by side) whose other points, the loose ones left out, fall into
/// two or more clusters of at least `min_points` with centroids at least `min_separation` [m]
/// apart (a joint's diameter) becomes those clusters, the layer and loose points each going to
/// the one with the nearest grid cell (a point with none in a neighbouring cell is left out). A
/// cluster the layer does not join is returned as it is. Largest first, as euclideanClusters.
/// Deterministic.
std::vector<std::vector<size_t>> splitAtSupport(const std::vector<CloudPoint>& points,
                                                std::vector<std::vector<size_t>> clusters,
                                                double tolerance, size_t min_points,
                                                double min_separation,
                                                const EstimatorConfig::AxisFit& axis_fit);

/// What the decisions have shown about one instance of a label (a cluster of its carved points,
/// at one place) over the last cycles (EstimatorConfig::Instances).
struct InstanceMemory {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< the last decided fit's origin
  Eigen::Vector3d z = Eigen::Vector3d::UnitZ();      ///< the last decided fit's axis direction
  /// Mean fit cost (the refined fit's mean truncated squared residual [m^2]) of the last
  /// `decisions` decisions (running mean).
  double mean_cost = 0.0;
  int decisions = 0;     ///< at most instances.memory_decisions
  /// Mean tool-joint radius offset (RadiusCheck::offset [m]) of the last `radius_samples`
  /// decisions that measured it (running mean, at most instances.memory_decisions).
  double radius_offset = 0.0;
  int radius_samples = 0;
  /// Spread of those measurements (running variance [m^2], weighted as the mean).
  double radius_variance = 0.0;
  int64_t stamp_ns = 0;  ///< the last decision's cycle
  bool chosen = false;   ///< the label's end was this instance at its last decided pose
};

/// The entry of `memory` whose tool joint shows `entry` to be another pipe size, or null: both
/// have at least min_decisions radius measurements, the other's mean is nearer the model's
/// radius, and the two differ by more than radius_difference plus two standard errors of the
/// difference (from the measurements' spread; never when radius_difference is 0).
const InstanceMemory* otherSize(const InstanceMemory& entry,
                                const std::vector<InstanceMemory>& memory,
                                const EstimatorConfig::Instances& config);

/// The remembered instance (decided at least min_decisions times, within memory_s of stamp_ns)
/// that a fit at (origin, z) is the flipped fit of, or null: its axis reversed against the
/// entry's, within track_gate of the entry's axis line and at most reversal_reach along it,
/// with no entry of its own direction within track_gate (never when reversal_reach is 0).
const InstanceMemory* reversedAgainst(const Eigen::Vector3d& origin, const Eigen::Vector3d& z,
                                      const std::vector<InstanceMemory>& memory,
                                      int64_t stamp_ns, const EstimatorConfig::Instances& config);

/// Whether two ends lie on one axis line: their axes antiparallel within max_angle_deg (a
/// pipe's two ends, and a box end and the pin end stabbed into it, face each other), and each
/// origin within `reach` [m] of the line through the other along their mean axis.
bool coaxialEnds(const Eigen::Vector3d& a_origin, const Eigen::Vector3d& a_z,
                 const Eigen::Vector3d& b_origin, const Eigen::Vector3d& b_z, double reach,
                 double max_angle_deg);

/// Whether two ends lie on one joint facing one way: their axes parallel within max_angle_deg,
/// each origin within `reach` [m] of the line through the other along their mean axis, and the
/// origins less than `along` [m] apart along it. A box end and a pin end never do (a pin end
/// stabbed into a box end faces it: coaxialEnds); one model fitted to the other's joint does.
bool endsOnOneJoint(const Eigen::Vector3d& a_origin, const Eigen::Vector3d& a_z,
                    const Eigen::Vector3d& b_origin, const Eigen::Vector3d& b_z, double reach,
                    double along, double max_angle_deg);

/// One instance decided this cycle, for chooseInstance.
struct InstanceFit {
  bool competes = false;  ///< a valid fit that may be the label's end (the caller decides)
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double cost = 0.0;  ///< ProfileFitResult::cost
  RadiusCheck radius;  ///< the fit's radius check (not ok: not measured)
  Eigen::Vector3d z = Eigen::Vector3d::UnitZ();  ///< the fit's axis direction
};

/// The choice among a label's instances: `index` into the fits, or -1 with `reason`.
struct InstanceChoice {
  int index = -1;
  std::string reason;
};

/// Chooses a label's end among its instances decided this cycle (`fits`; `track` is the index
/// of the one its track followed, or -1) and updates `memory` (entries not decided for
/// instances.memory_s are forgotten first). Each competing fit's cost joins its memory entry
/// (the one within instances.track_gate; a new one otherwise), and instances compete by their
/// entries' mean cost:
///  - an entry not fitted this cycle whose place still holds at least `min_points` of the
///    label's cut-out points (`points_near(origin, radius)`) competes too when it has
///    min_decisions decisions: when it is the best, none is chosen (a worse one is not taken in
///    its place);
///  - an instance whose tool-joint radius (each fit's `radius`; the entry's mean over at least
///    min_decisions of them) differs by more than instances.radius_difference from another
///    entry's that is nearer the model's is another pipe size (otherSize): it does not compete
///    (when that leaves none, the reason says so);
///  - the incumbent (the track's instance when it competes, else the entry chosen last) keeps
///    its place unless another is better by instances.min_cost_margin over at least
///    instances.min_decisions decisions;
///  - otherwise none is chosen while the best has fewer than min_decisions decisions and
///    others compete - or, without an incumbent, while any other instance has fewer, counting
///    an entry with fewer whose place still holds points and (while the best has fewer) a fit
///    of this cycle that does not compete - or while the runner-up is within min_cost_margin
///    (two alike).
/// Deterministic. `label` names the label in the reasons. With no competing fit, index -1 and
/// an empty reason (the caller explains).
/// How many of a label's cut-out points lie within `radius` [m] of `origin` [world].
using PointsNear = std::function<size_t(const Eigen::Vector3d& origin, double radius)>;
InstanceChoice chooseInstance(std::vector<InstanceMemory>* memory,
                              const std::vector<InstanceFit>& fits, int track, int64_t stamp_ns,
                              const PointsNear& points_near, size_t min_points,
                              const EstimatorConfig::Instances& config, const std::string& label);


}  // namespace drill_pipe_pose
