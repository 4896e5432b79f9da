// One end's pipe type from its measured tool-joint radius (pipe_type.hpp).

#include "drill_pipe_pose/core/estimator/pipe_type.hpp"

#include <algorithm>
#include <cmath>

namespace drill_pipe_pose {

void RadiusMean::add(double radius, double std) {
  if (!std::isfinite(radius) || !std::isfinite(std)) return;
  ++n_;
  sum_ += radius;
  sum2_ += radius * radius;
  std_sum_ += std;
}

double RadiusMean::spread() const {
  if (n_ == 0) return 0.0;
  const double m = mean();
  const double var = sum2_ / static_cast<double>(n_) - m * m;
  // At least the mean stated error: a steady view repeats its noise, and a few equal
  // measurements have no scatter at all.
  return std::max(std::sqrt(std::max(var, 0.0)), std_sum_ / static_cast<double>(n_));
}

double RadiusMean::logLikelihood(double radius, double wear, double systematic) const {
  if (n_ == 0) return 0.0;
  const double s = spread();
  const double var = s * s / static_cast<double>(n_) + systematic * systematic;
  double d = mean() - radius;
  if (d < 0) d = std::min(0.0, d + wear);
  return -d * d / (2 * var);
}

std::vector<double> TypeEvidence::probabilities(const std::vector<PipeCandidate>& candidates,
                                                const TypingConfig& config) const {
  std::vector<double> p(candidates.size(), candidates.empty() ? 0.0 : 1.0 / candidates.size());
  if (joint.count() == 0 || candidates.empty()) return p;
  const bool use_tube = tube.count() >= static_cast<size_t>(config.min_measurements);
  std::vector<double> logl(candidates.size());
  for (size_t k = 0; k < candidates.size(); ++k) {
    const ToolJointDimensions& d = candidates[k].dims;
    logl[k] = joint.logLikelihood(d.tool_joint_od / 2, config.wear, config.systematic);
    // A tube does not wear: no allowance.
    if (use_tube) logl[k] += tube.logLikelihood(d.tube_od / 2, 0.0, config.systematic);
  }
  const double top = *std::max_element(logl.begin(), logl.end());
  double total = 0;
  for (size_t k = 0; k < p.size(); ++k) total += p[k] = std::exp(logl[k] - top);
  for (double& v : p) v /= total;
  return p;
}

int topType(const std::vector<double>& probabilities) {
  if (probabilities.empty()) return -1;
  return static_cast<int>(std::max_element(probabilities.begin(), probabilities.end()) -
                          probabilities.begin());
}

}  // namespace drill_pipe_pose
