#pragma once
// Scoring estimates against ground truth (the `evaluate` tool, the bench and the tests): ground
// truth interpolated at each cycle stamp, errors per core/metrics.hpp, statistics per end.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <iosfwd>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/metrics.hpp"

namespace drill_pipe_pose {

/// Ground-truth track of one end: poses sampled in time (any rate, sorted by add order).
class GroundTruthTrack {
 public:
  void add(int64_t stamp_ns, const Eigen::Isometry3d& T_world_end);
  bool empty() const { return stamps_.empty(); }
  size_t size() const { return stamps_.size(); }
  int64_t firstStamp() const { return stamps_.front(); }
  int64_t lastStamp() const { return stamps_.back(); }
  /// Pose at `stamp_ns` (linear position, slerp rotation between the bracketing samples). False
  /// when outside [first, last] by more than `max_extrapolation_ns`.
  bool at(int64_t stamp_ns, Eigen::Isometry3d* T_world_end,
          int64_t max_extrapolation_ns = 50000000) const;

 private:
  void sortIfNeeded() const;
  mutable bool sorted_ = true;
  mutable std::vector<int64_t> stamps_;
  mutable std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> poses_;
};

/// One estimate of one end in one cycle.
struct EstimateSample {
  int64_t stamp_ns = 0;
  EndLabel label = EndLabel::kBoxEnd;
  bool valid = false;
  /// Computed in this cycle (false: a valid end's last pose repeated while it is young enough).
  bool fresh = true;
  Eigen::Isometry3d T_world_end = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

/// Result of scoring one end.
struct EndEvaluation {
  EndLabel label = EndLabel::kBoxEnd;
  bool present = false;  ///< ground truth exists for this end
  ErrorStats stats;
  std::vector<int64_t> stamps;  ///< stamp of each scored estimate (same order as stats.errors)
  /// Fraction of scored estimates whose position error lies inside the 3-sigma ellipsoid of the
  /// reported position covariance (NaN when no covariance was given).
  double within_3sigma = 0;
  /// The same for the axis: fraction of scored estimates whose tilt (the rotation vector of
  /// R_true^T R_est, in the world) lies inside the 3-sigma ellipsoid of the reported rotation
  /// covariance (roll has a huge variance there, so it is the tilt that counts). NaN when no
  /// rotation covariance was given.
  double axis_within_3sigma = 0;
  /// The reported position sigma against the actual error, over the scored estimates with a
  /// covariance: sqrt(mean trace(P) / mean |error|^2), i.e. the rms of the reported sigmas over
  /// the three axes divided by the rms of the errors' components. 1: honest on average; above:
  /// inflated. NaN without covariance or without error.
  double sigma_to_error = 0;
  /// Position error [m] of the fresh estimates (this cycle's poses, not a repeated one): median
  /// and 95th percentile; NaN without fresh estimates.
  double fresh_median_error = 0;
  double fresh_p95_error = 0;
  Eigen::Vector3d true_position = Eigen::Vector3d::Zero();  ///< mean ground-truth position
  /// Lag: mean signed position error [m] along the ground truth's direction of motion, over the
  /// estimates taken while the end moved faster than EvaluationOptions::moving_speed (negative:
  /// behind the true pose). NaN when it never moved.
  double mean_lag = 0;
  size_t moving_estimates = 0;
};

struct EvaluationOptions {
  double expected_rate_hz = 30.0;  ///< expected cycles per second of ground truth (the cycle rate)
  /// Expected cycles; 0 = expected_rate_hz * ground-truth span.
  size_t expected_cycles = 0;
  double moving_speed = 0.02;  ///< [m/s] faster counts as moving (lag statistics)
};

/// Scores `estimates` of each end against its ground-truth track (index = EndLabel).
std::array<EndEvaluation, kNumEnds> evaluate(const std::array<GroundTruthTrack, kNumEnds>& truth,
                                             const std::vector<EstimateSample>& estimates,
                                             const EvaluationOptions& options = {});

/// Writes one CSV row per scored estimate:
/// stamp_s,end,ex,ey,ez,err,along,across,axis_deg,rx_deg,ry_deg.
void writeErrorCsv(const std::array<EndEvaluation, kNumEnds>& evals, std::ostream& out);

/// Prints the thesis-style table (mean and sigma of x, y, z, rotation about x and y) and the
/// symmetry-aware errors with success rates, per end.
void printEvaluation(const std::array<EndEvaluation, kNumEnds>& evals, std::ostream& out);

/// One end a cycle reported (several pipes at once: the primary pair and every other end).
struct ReportedEnd {
  int64_t stamp_ns = 0;  ///< the cycle's stamp
  EndLabel label = EndLabel::kBoxEnd;
  uint32_t id = 0;  ///< instance id
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< [m] world
  std::string type;  ///< its published pipe type ("": none)
  std::vector<std::string> type_names;  ///< every candidate type...
  std::vector<double> type_probabilities;  ///< ...and its probability
};

/// The pipe types published over one end's reports.
struct TypeTally {
  size_t reports = 0;                         ///< reports with a type
  std::map<std::string, size_t> top;          ///< reports per published type
  std::map<std::string, double> probability;  ///< summed probability per type
  /// Per type: its least probability in a report that published another.
  std::map<std::string, double> least_not_top;
  /// Reports per published type whose own probability was above kConfidentProbability.
  std::map<std::string, size_t> confident;
  /// A published type above this probability is a confident call (the pipe-type issue's line:
  /// never a wrong type above it).
  static constexpr double kConfidentProbability = 0.9;
  /// One report: its published type, and every candidate's name and probability.
  void add(const std::string& type, const std::vector<std::string>& names,
           const std::vector<double>& probabilities);
};

/// The types reported on one true end (InstanceEvaluation::types).
struct TrueEndTypes : TypeTally {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< [m] its last true origin
};

/// The true ends at each capture stamp, per label, in the simulator's (stable) order.
using TrueEnds = std::array<std::map<int64_t, std::vector<Eigen::Vector3d>>, kNumEnds>;

/// Reported ends against every true end (evaluateInstances).
struct InstanceEvaluation {
  size_t cycles = 0;        ///< cycles with a report or a truth
  size_t true_ends = 0;     ///< true ends per cycle (the most seen)
  size_t end_cycles = 0;    ///< (cycle, true end) pairs
  size_t reported = 0;      ///< ...with a report of its label within match_distance
  /// Per true end (label, index in the simulator's order): its cycles and those reported.
  std::map<std::pair<int, size_t>, std::pair<size_t, size_t>> per_end;
  size_t id_pairs = 0;      ///< consecutive cycles in which one true end was reported
  size_t id_kept = 0;       ///< ...under the same id
  size_t mixed_ids = 0;     ///< ids reported on more than one true end
  size_t stray = 0;         ///< reports with no true end of their label within match_distance
  size_t near_other = 0;    ///< reports within near_distance of another end's true position
  std::vector<ReportedEnd> near_examples;  ///< the first few of those (for a diagnosis)
  /// The first few stray reports with their distance [m] to their label's nearest true end.
  std::vector<std::pair<ReportedEnd, double>> stray_examples;
  std::map<uint32_t, std::set<std::pair<int, size_t>>> id_truth;  ///< id -> (label, true end)
  std::map<std::pair<int, size_t>, TrueEndTypes> types;  ///< per true end, its reports' types
};

/// A scored end's tool joint as the simulator rendered it: what a measured OD is judged against
/// (its wear included, which the scene file's OD is not).
struct TrueJoint {
  EndLabel label = EndLabel::kBoxEnd;
  std::string pipe;        ///< the scene's pipe it belongs to
  double nominal_od = 0;   ///< [m] tool-joint OD in the scene file
  double rendered_od = 0;  ///< [m] ...less its wear, as rendered
};

/// The joints as YAML (a list of maps: label, pipe, nominal_od, rendered_od) and back. Parsing
/// throws InputError (core/errors.hpp) naming the entry and field at fault.
std::string trueJointsYaml(const std::vector<TrueJoint>& joints);
std::vector<TrueJoint> parseTrueJoints(const std::string& yaml);

/// Every report matched to the nearest true end of its label at the cycle's stamp (the latest
/// truth at or before it) within match_distance [m]; see InstanceEvaluation.
InstanceEvaluation evaluateInstances(const TrueEnds& truth, const std::vector<ReportedEnd>& reports,
                                     double match_distance = 0.1, double near_distance = 0.2);

}  // namespace drill_pipe_pose
