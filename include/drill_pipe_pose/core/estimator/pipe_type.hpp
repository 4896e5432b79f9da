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
// The mean measured against the current model decides among the types of its joint OD; another
// OD is decided by type trials (trialTypes, chooseTrial): the end refitted with each nearby
// type's model and measured against it.
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
  /// A type trial (TypeTrial) replaces the end's type only when the other type's joint explains
  /// the points better by this much [m] of radius (chosen on the thesis_vertical seed-92 bags
  /// of every catalogue size, see chooseTrial; one trial's offset scatters by about 0.5 mm).
  double trial_margin = 0.00025;
  /// [m] the configured type (tool_joint/type, the string the rig runs) needs a trial this much
  /// worse than another's to be left, and wins this much back: a 5" NC50 joint worn 3 mm reads
  /// up to 1.9 mm thin on its pin end, about as near the 6-3/8" joint's radius 3.2 mm below
  /// (thesis_vertical_worn, seeds 94 and 95), and through the node at quarter speed a 5" NC50
  /// pin end read as the 7" joint 4.8 mm above (estimator_replay rostest, seed 3): 5 mm.
  double prior_margin = 0.005;
};

/// One type tried at a decision: the end refitted with the type's model from its current pose,
/// and its joint's radius measured against that model (radiusOffset).
struct TypeTrial {
  int type = -1;      ///< index into the candidates
  bool ok = false;    ///< the refit converged and the radius was measured
  double offset = 0;  ///< [m] measured minus the type's joint radius (a thinner joint: negative)
};

/// The types worth a trial for an end fitted with type `current` whose joint reads `mean` [m]
/// (the evidence's mean radius, measured against the current model): the current type first,
/// then one per other joint OD (the first such candidate) on the reading's side of the current
/// radius and within three times its deviation (measured against a model of another size, a
/// joint reads about halfway between the two).
std::vector<int> trialTypes(const std::vector<PipeCandidate>& candidates, int current,
                            double mean, const TypingConfig& config);

/// The trial whose joint fits its own model best: the smallest offset beyond the wear allowance
/// (a joint up to typing.wear thinner than its model counts as a fit), plus a quarter of the
/// whole offset (of two types that both pass for worn, the one nearer the reading), less
/// typing.prior_margin for the `preferred` type (the configured one). The current type (the
/// first trial) stays unless another beats it by typing.trial_margin. Returns a candidate
/// index, or -1 when no trial is ok.
int chooseTrial(const std::vector<TypeTrial>& trials, const TypingConfig& config,
                int preferred = -1);

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
