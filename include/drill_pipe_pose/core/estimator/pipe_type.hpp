#pragma once
// The pipe type of one end, measured (ROS-free). At each fit the end's tool-joint radius is
// measured with its pose eliminated (radiusOffset), in absolute terms now that the cameras'
// depth offsets are calibrated, and so is the tube's radius where the model's tube is seen; the
// end's measurements on its track are averaged, and each allowed type
// (EstimatorConfig::candidates) gets the likelihood of those means, per measured surface:
//   d = mean - R_type, taken as 0 for a joint worn by up to typing.wear below R_type (small:
//   the measurement reads joints at or over nominal, TypingConfig::wear),
//   log L = -d^2 / (2 (s^2 / n + max(typing.systematic, s / 2)^2)),
// s the measurements' spread, n their number: the part every measurement shares (the sensor's
// depth bias, paint) does not average out, so the evidence never grows past typing.systematic.
// The tube counts from typing.min_measurements measurements on (a glimpse of tube is not one),
// and only among the types that share the current model's joint OD: measured against a model of
// another size, a surface reads only part of the way to its own radius.
// For that reason the joint OD is decided on searched radii (searchRadius): at the track's
// decisions the end is refitted with models of other radii until one explains the points. Their
// mean is robust (SearchedRadii): the last 64 searches, less those far off their median.
// Types whose joints the data cannot tell apart (4-1/2" NC50 and 5" NC50: both 6-5/8" OD) keep
// equal probabilities: the top one is then ambiguous and published as such, never confidently.

#include <cstddef>
#include <deque>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

/// A pipe type the estimator may give an end: a catalogue entry's name and geometry.
struct PipeCandidate {
  std::string name;
  ToolJointDimensions dims;
};

/// The classifier's settings (EstimatorConfig::Typing).
struct TypingConfig {
  bool enabled = true;
  /// [m] the error of the mean measured radius that no averaging removes (chosen on the
  /// thesis_vertical seed-91 bags: the 5" NC50 joint measured 0.4-1.1 mm off its radius per
  /// scene; 1.5 mm keeps joints 10 mm apart in OD (5 mm in radius) more than 3 sigma apart).
  double systematic = 0.0015;
  /// [m] a measured radius up to this below a type's is as likely as the type's own (a worn
  /// joint). Small: the allowance assumes the searched radius reads a joint's own, worn radius,
  /// and it does not. On the fitted Kinect v2 model, joints rendered 0-2 mm under nominal OD read
  /// 1.4 mm over it on average standing (box ends +1.6 to +3.4 mm, pin ends -0.8 to +1.0) and
  /// -0.9 / +2.3 mm (box / pin) lying on the catwalk, so an allowance pushes the probability to
  /// the next larger size. Chosen on seed 200 (every catalogue entry, scripts/bench_types' bags:
  /// rows meeting the type target, thesis_vertical / catwalk: 1.5 mm 6 / 4 of 10, 0.75 mm 9 / 5,
  /// 0.5 mm 9 / 5, 0 10 / 5) and seed 93's worn 5" NC50 joints (3 mm under nominal, which read
  /// 3.2 and 5.1 mm under it: published nominal in 100 % of cycles with 0.5 mm, 14 % with 0).
  double wear = 0.0005;
  /// A decision changes the end's type (and the model it is fitted with) only when the new top
  /// type is at least this probable...
  double switch_probability = 0.9;
  /// ...and the mean holds at least this many measurements.
  int min_measurements = 5;
};

/// The result of a radius search (searchRadius).
struct RadiusSearch {
  bool ok = false;
  double radius = 0.0;  ///< [m] the joint's measured radius
  int refits = 0;       ///< models the end was refitted with
  /// The secant's last gain, -d offset / dR: how far a reading moves toward the joint's own
  /// radius per unit of model radius (1: all the way).
  double gain = 0.0;
  /// [m] the radius's standard deviation: the last offset's over the gain.
  double std = 0.0;
};

/// The joint radius R at which a model of that radius explains the points: the root of
/// offset(R), the radius offset measured against a model of joint radius R after the end is
/// refitted with it (`offset_at(R, &offset, &std)`, with the offset's standard deviation; false
/// when the refit or the measurement fails).
/// Measured against a model of the wrong size, a joint reads only part of the way to its own
/// radius (about halfway in the thesis lab, a seventh of the way on the catwalk, where the
/// points outside the smaller model's silhouette drop out), so one measurement is not the
/// radius; the search steps along the secant of offset(R), starting from r0 with the
/// halfway gain, until the offset is below 0.2 mm or after 5 refits, and stays in
/// [r_min, r_max]. The radius is the last R plus its offset over the secant's gain, and so is
/// its standard deviation.
RadiusSearch searchRadius(const std::function<bool(double, double*, double*)>& offset_at,
                          double r0, double r_min, double r_max);

/// Measurements of one radius on an end's track: every one of them, or with a window
/// (SearchedRadii) the last `window` less those far off their median (add).
class RadiusMean {
 public:
  RadiusMean() = default;
  /// A radius measurement [m] (absolute) with its standard deviation [m].
  void add(double radius, double std);
  /// The measurements the mean is over.
  size_t count() const { return n_; }
  /// Every measurement added (finite), and the latest one [m] (0 without one).
  size_t added() const { return added_; }
  double last() const { return last_; }
  /// [m] the mean measured radius (0 without one).
  double mean() const { return n_ ? sum_ / static_cast<double>(n_) : 0.0; }
  /// [m] the measurements' scatter, at least their mean stated error.
  double spread() const;
  /// Log-likelihood of a type whose radius is `radius` [m] (with the wear allowance `wear`).
  double logLikelihood(double radius, double wear, double systematic) const;

 protected:
  /// `window` > 0: over the last `window` measurements, robustly (add).
  explicit RadiusMean(size_t window) : window_(window) {}

 private:
  size_t window_ = 0;
  std::deque<std::pair<double, double>> recent_;  ///< with a window: (radius, std), oldest first
  size_t added_ = 0;
  double last_ = 0.0;
  size_t n_ = 0;  ///< the sums below are over these measurements
  double sum_ = 0.0, sum2_ = 0.0, std_sum_ = 0.0;
};

/// An end's searched joint radii on its track (searchRadius): the last kWindow searches; once
/// there are kMinToTrim of them, less those farther from their median than 3 times their robust
/// spread (1.4826 times the median absolute deviation, at least half their mean stated error).
/// A lying joint's searches now and then run to the end of the searched range or far off
/// (catwalk, seed 200: a 3-1/2" NC38 5" OD pin end read 101 mm four times among readings of
/// 117-138 mm), and a plain mean follows them.
class SearchedRadii : public RadiusMean {
 public:
  /// A 10 s track searches up to about 45 times; on a long track the oldest searches roll off.
  static constexpr size_t kWindow = 64;
  SearchedRadii() : RadiusMean(kWindow) {}
};

/// One end's type evidence on its track: its tool joint's radius, and its tube's.
struct TypeEvidence {
  RadiusMean joint, tube;
  void reset() { *this = TypeEvidence(); }
  /// Probability of each candidate (same order), uniform without a measurement; `current`: the
  /// index of the type whose model the measurements were made with (-1: the joint alone).
  std::vector<double> probabilities(const std::vector<PipeCandidate>& candidates,
                                    const TypingConfig& config, int current = -1) const;
};

/// Probability of each candidate's joint radius on the product of the likelihoods of
/// `means` (each a RadiusMean of absolute radii; the empty ones are left out), uniform without
/// a measurement.
std::vector<double> radiusProbabilities(const std::vector<const RadiusMean*>& means,
                                        const std::vector<PipeCandidate>& candidates,
                                        const TypingConfig& config);

/// Whether two candidates' joints are one size (ODs within 1 mm: the catalogue's differ by
/// 3.2 mm or more where they differ).
bool sameJointOd(const PipeCandidate& a, const PipeCandidate& b);

/// The summed probability of the candidates whose joint OD is that of candidate `of`.
double jointOdProbability(const std::vector<double>& probabilities,
                          const std::vector<PipeCandidate>& candidates, int of);

/// Each joint OD's summed probability taken from `by_od`, split among the candidates of that OD
/// as `within` splits it (evenly where `within` gives them nothing). The searched radii say
/// which joint OD (absolute, whatever the model), the evidence on the track which type within it
/// (the tube).
std::vector<double> splitByJointOd(const std::vector<double>& by_od,
                                   const std::vector<double>& within,
                                   const std::vector<PipeCandidate>& candidates);

/// The index of the largest probability (the first of equals); -1 when empty.
int topType(const std::vector<double>& probabilities);

/// [m] Two types whose tool-joint ODs differ by less than this, and whose tubes by less than
/// kDistinguishableTubeOd, are a pair the sensor cannot tell apart: the joint OD it measures is
/// good to about +-1-2 mm per scene (docs/pipe_types.md), and wear only takes a joint down, by up
/// to about 3 mm; so 6 mm between two new types is a clear call and 3 mm is not.
constexpr double kDistinguishableJointOd = 0.006;
/// [m] ...a tube that much thinner or thicker tells them apart where enough of it is in view.
constexpr double kDistinguishableTubeOd = 0.010;

/// Two allowed types the sensor cannot tell apart (kDistinguishable*).
struct CloseTypes {
  std::string a, b;
  double joint_od_gap = 0.0;  ///< [m] |OD a - OD b|
  double tube_od_gap = 0.0;   ///< [m] |tube a - tube b|
};

/// Every pair of `candidates` the sensor cannot tell apart, in the candidates' order.
std::vector<CloseTypes> closeTypes(const std::vector<PipeCandidate>& candidates);

/// The start-up warning about the tally: "" when the sensor can tell every pair of `candidates`
/// apart. With `every_entry` (pipe_types: [all]) it says how to set the tally rather than
/// listing the pairs; else it names each pair.
std::string tallyWarning(const std::vector<PipeCandidate>& candidates, bool every_entry);

}  // namespace drill_pipe_pose
