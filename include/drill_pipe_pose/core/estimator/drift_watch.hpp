#pragma once
// The drift watch: how each camera's points disagree with the fused fit, averaged over capture
// time, and which cameras disagree enough to be flagged (a bumped camera: its published
// calibration no longer holds). ROS-free; PoseEstimator runs it after each cycle's fit
// (EstimatorConfig::Drift) and leaves flagged cameras out of the next cycles' fits.
//
// Per cycle and camera: the translation t that best moves the fitted model surfaces of the valid
// ends it saw onto its points (point to plane, least squares; observeShift), split into the
// shift along the camera's view ray (t . u, u the unit ray from the camera to the end) and a
// rotation (the lateral rest of t over the range: a rotated camera moves its points sideways by
// about range x angle). The shift along the ray that the cycle's cameras share (their median,
// with 3 or more measured) is taken off: it is no one camera's drift. Per camera, both are
// averaged with an exponential weight of time constant drift.time_constant [s] of capture time
// (DriftWatch). Each camera has views whose disagreement is not drift (the sensor's depth bias
// differs with range and incidence), so its mean over its first drift.learn_time seconds on each
// set of ends it measures (box, pin, both) is learned as its baseline there (when an end comes
// into view later, a pin end whose type was still being measured, the new set is learned then),
// and what is flagged is the change from the baseline of the set measured: above max_ray_shift or
// max_rotation, cleared when both fall below release_fraction of them (hysteresis). A
// disagreement above absolute_factor times the limits is flagged without a baseline (a camera
// bumped before the watch learned).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"

namespace drill_pipe_pose {

/// One camera's points against the fitted models in one cycle: the normal equations of the
/// translation t (world) that moves the model surfaces onto the points, sum over the points of
/// n n^T and n d (n the unit surface normal at the closest model point, d the distance along
/// it), and the view geometry.
struct ShiftObservation {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Vector3d ray_sum = Eigen::Vector3d::Zero();  ///< sum of unit rays camera -> end, per point
  double range_sum = 0.0;  ///< [m] sum of ranges camera -> end, per point
  size_t points = 0;
  void add(const ShiftObservation& o);
  /// The translation [m, world] (ridge-regularised: a direction that fewer than 0.5 % of the
  /// points' normals constrain stays near 0).
  Eigen::Vector3d solve() const;
};

/// A fitted end as the drift watch sees it: the model at pose (origin, unit axis z) [world].
struct FittedSurface {
  const ProfileModel* model = nullptr;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  /// [m] end-frame z below which the model is not trusted (worn tong: trustedMinZ).
  double min_z = -std::numeric_limits<double>::infinity();
  /// [m] world height below which points are not used (a support under the joint).
  double min_world_z = -std::numeric_limits<double>::infinity();
};

/// The observation of one camera (at `eye`, world) on one fitted end from its points [world]:
/// a few passes of a translation-only ICP, the points within `gate` of the surface in the first,
/// those within 0.3 gate of the surface moved by the shift so far in the others. At most 800
/// points are read (every k-th).
ShiftObservation observeShift(const std::vector<Eigen::Vector3f>& points,
                              const Eigen::Vector3d& eye, const FittedSurface& surface,
                              double gate);

/// One camera's state in the drift watch.
struct CameraDriftStatus {
  std::string camera;
  /// [m] running shift along the view ray since the baseline (+: away from the camera)
  double ray_shift = 0.0;
  double rotation = 0.0;   ///< [deg] running rotation since the baseline (lateral / range)
  /// [rad] running lateral offset over the range since the baseline (a world direction; its
  /// norm is rotation)
  Eigen::Vector3d lateral = Eigen::Vector3d::Zero();
  /// The running disagreement itself, baseline included ([m] along the ray; [rad] lateral).
  double disagreement_ray = 0.0;
  Eigen::Vector3d disagreement_lateral = Eigen::Vector3d::Zero();
  double baseline_ray = 0.0;  ///< [m] learned baseline (see the file comment)
  Eigen::Vector3d baseline_lateral = Eigen::Vector3d::Zero();  ///< [rad]
  bool learning = true;    ///< still learning its baseline (never flagged then)
  size_t samples = 0;      ///< cycles it was measured in
  int64_t first_stamp_ns = 0;  ///< capture stamp of its first observation
  bool flagged = false;    ///< disagrees with the fused fit (hysteresis, see the file comment)
  bool left_out = false;   ///< its points were left out of this cycle's fit
  bool measured = false;   ///< observed in this cycle
  size_t points = 0;       ///< points of this cycle's observation
  int64_t last_stamp_ns = 0;  ///< capture stamp of its last observation (0: never)
  int64_t flagged_since_ns = 0;  ///< capture stamp at which it was flagged (with flagged)
};

/// One cycle's observations by camera, one per end slot (EndLabel's index; an observation of
/// no points: that end not measured by that camera).
using DriftObservations = std::map<std::string, std::array<ShiftObservation, kNumEnds>>;

/// The running per-camera estimates and flags.
class DriftWatch {
 public:
  DriftWatch() = default;
  explicit DriftWatch(const EstimatorConfig::Drift& config) : config_(config) {}
  /// One cycle's observations by camera and end at capture time stamp_ns [ns]. Each camera
  /// learns a baseline per set of ends it measures (box, pin, both: its first learn_time seconds
  /// on that set): when an end comes into a camera's view later, the new set is learned then,
  /// and only changes from a learned baseline count. Cameras without an observation keep their
  /// estimate and flag (measured = false).
  void updateByEnd(int64_t stamp_ns, const DriftObservations& observations);
  bool flagged(const std::string& camera) const;
  /// How far past its limits a camera is: max(|ray shift| / max_ray_shift, rotation /
  /// max_rotation, its absolute disagreement's ratio / absolute_factor) (0 for an unknown
  /// camera).
  double excess(const std::string& camera) const;
  /// Every camera seen so far, by name.
  std::vector<CameraDriftStatus> status() const;
  void reset() {
    cams_.clear();
    baselines_.clear();
  }

 private:
  /// One camera's learned baseline on one set of ends.
  struct SetBaseline {
    double ray = 0.0;  ///< [m]
    Eigen::Vector3d angle = Eigen::Vector3d::Zero();  ///< [rad]
    size_t samples = 0;
    int64_t first_stamp_ns = 0, last_stamp_ns = 0;
    bool learning = true;
  };
  /// Sets of ends a camera can measure in a cycle (a bit per end).
  static constexpr unsigned kEndSets = 1u << kNumEnds;
  /// One camera's sample of one cycle on the set of ends `ends` (ray shift [m] with the cycle's
  /// common part off, lateral angle [rad]).
  void updateCamera(int64_t stamp_ns, unsigned ends, double ray, const Eigen::Vector3d& angle,
                    size_t points, CameraDriftStatus* s);
  /// The ratio of the camera's absolute disagreement to the limits (see excess).
  double absoluteExcess(const CameraDriftStatus& s) const;
  EstimatorConfig::Drift config_;
  std::map<std::string, CameraDriftStatus> cams_;
  std::map<std::string, std::array<SetBaseline, kEndSets>> baselines_;
};

/// "shift along the view ray +12.3 mm, rotation 0.45 deg" (since the baseline) for a message.
std::string describeDrift(const CameraDriftStatus& s);

}  // namespace drill_pipe_pose
