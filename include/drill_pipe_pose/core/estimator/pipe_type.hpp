#pragma once
// The pipe type of one end, measured (ROS-free). At each fit the end's tool-joint radius is
// measured with its pose eliminated (radiusOffset), in absolute terms now that the cameras'
// depth offsets are calibrated, and so is the tube's radius where the model's tube is seen; the
// end's measurements on its track are averaged, and each allowed type
// (EstimatorConfig::candidates) gets the likelihood of those means, per measured surface:
//   d = mean - R_type, taken as 0 for a joint worn by up to typing.wear below R_type,
//   log L = -d^2 / (2 (s^2 / n + typing.systematic^2)),
// s the measurements' spread, n their number: the part every measurement shares (the sensor's
// depth bias, paint) does not average out, so the evidence never grows past typing.systematic.
// The tube counts from typing.min_measurements measurements on (a glimpse of tube is not one),
// and only among the types that share the current model's joint OD: measured against a model of
// another size, a surface reads about halfway between the two.
// Types whose joints the data cannot tell apart (4-1/2" NC50 and 5" NC50: both 6-5/8" OD) keep
// equal probabilities: the top one is then ambiguous and published as such, never confidently.

#include <cstddef>
#include <string>
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
  /// joint: OD down to 3 mm under nominal).
  double wear = 0.0015;
  /// A decision changes the end's type (and the model it is fitted with) only when the new top
  /// type is at least this probable...
  double switch_probability = 0.9;
  /// ...and the mean holds at least this many measurements.
  int min_measurements = 5;
};

/// Measurements of one radius on an end's track.
class RadiusMean {
 public:
  /// A radius measurement [m] (absolute) with its standard deviation [m].
  void add(double radius, double std);
  size_t count() const { return n_; }
  /// [m] the mean measured radius (0 without one).
  double mean() const { return n_ ? sum_ / static_cast<double>(n_) : 0.0; }
  /// [m] the measurements' scatter, at least their mean stated error.
  double spread() const;
  /// Log-likelihood of a type whose radius is `radius` [m] (with the wear allowance `wear`).
  double logLikelihood(double radius, double wear, double systematic) const;

 private:
  size_t n_ = 0;
  double sum_ = 0.0, sum2_ = 0.0, std_sum_ = 0.0;
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

/// The index of the largest probability (the first of equals); -1 when empty.
int topType(const std::vector<double>& probabilities);

}  // namespace drill_pipe_pose
