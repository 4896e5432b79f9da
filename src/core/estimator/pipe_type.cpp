// One end's pipe type from its measured tool-joint radius (pipe_type.hpp).

#include "drill_pipe_pose/core/estimator/pipe_type.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace drill_pipe_pose {

namespace {
/// [m] joints whose ODs differ by less than this are the same size (the catalogue's ODs differ
/// by 3.2 mm or more where they differ).
constexpr double kSameJointOd = 0.001;
}  // namespace

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
                                                const TypingConfig& config, int current) const {
  std::vector<double> p(candidates.size(), candidates.empty() ? 0.0 : 1.0 / candidates.size());
  if (joint.count() == 0 || candidates.empty()) return p;
  std::vector<double> logl(candidates.size());
  for (size_t k = 0; k < candidates.size(); ++k)
    logl[k] = joint.logLikelihood(candidates[k].dims.tool_joint_od / 2, config.wear,
                                  config.systematic);
  const double top = *std::max_element(logl.begin(), logl.end());
  double total = 0;
  for (size_t k = 0; k < p.size(); ++k) total += p[k] = std::exp(logl[k] - top);
  for (double& v : p) v /= total;
  // The tube splits the probability of the types that share the current type's joint OD (it is
  // measured against the current model's tube: against another size's it reads halfway, like
  // the joint). A tube does not wear: no allowance.
  if (current < 0 || current >= static_cast<int>(candidates.size()) ||
      tube.count() < static_cast<size_t>(config.min_measurements))
    return p;
  const double od = candidates[current].dims.tool_joint_od;
  std::vector<size_t> group;
  double group_p = 0, best = -std::numeric_limits<double>::infinity();
  std::vector<double> tl(candidates.size(), 0.0);
  for (size_t k = 0; k < candidates.size(); ++k)
    if (std::abs(candidates[k].dims.tool_joint_od - od) < kSameJointOd) {
      group.push_back(k);
      group_p += p[k];
      tl[k] = tube.logLikelihood(candidates[k].dims.tube_od / 2, 0.0, config.systematic);
      best = std::max(best, tl[k]);
    }
  double sum = 0;
  for (size_t k : group) sum += std::exp(tl[k] - best);
  for (size_t k : group) p[k] = group_p * std::exp(tl[k] - best) / sum;
  return p;
}

std::vector<int> trialTypes(const std::vector<PipeCandidate>& candidates, int current,
                            double mean, const TypingConfig& config) {
  std::vector<int> out;
  if (current < 0 || current >= static_cast<int>(candidates.size())) return out;
  out.push_back(current);
  const double r_cur = candidates[current].dims.tool_joint_od / 2;
  const double dev = mean - r_cur;
  // The window: from the current radius to three deviations away, widened by the error no
  // averaging removes (a reading that barely moves still tries the nearest sizes).
  const double lo = std::min(r_cur, r_cur + 3 * dev) - config.systematic;
  const double hi = std::max(r_cur, r_cur + 3 * dev) + config.systematic;
  std::vector<double> taken{candidates[current].dims.tool_joint_od};
  for (size_t k = 0; k < candidates.size(); ++k) {
    const double od = candidates[k].dims.tool_joint_od;
    if (od / 2 < lo || od / 2 > hi) continue;
    if ((od / 2 - r_cur) * dev < 0) continue;  // on the other side of the reading
    bool seen = false;
    for (double t : taken) seen = seen || std::abs(t - od) < kSameJointOd;
    if (seen) continue;
    taken.push_back(od);
    out.push_back(static_cast<int>(k));
  }
  return out;
}

int chooseTrial(const std::vector<TypeTrial>& trials, const TypingConfig& config, int preferred) {
  const auto score = [&](const TypeTrial& t) {
    const double d = t.offset < 0 ? std::min(0.0, t.offset + config.wear) : t.offset;
    return std::abs(d) + 0.25 * std::abs(t.offset) - (t.type == preferred ? config.prior_margin : 0.0);
  };
  if (trials.empty()) return -1;
  int best = -1;
  double best_score = std::numeric_limits<double>::infinity();
  for (const TypeTrial& t : trials)
    if (t.ok && score(t) < best_score) {
      best_score = score(t);
      best = t.type;
    }
  const TypeTrial& cur = trials.front();
  if (cur.ok && best != cur.type && score(cur) - best_score < config.trial_margin) return cur.type;
  return best;
}

int topType(const std::vector<double>& probabilities) {
  if (probabilities.empty()) return -1;
  return static_cast<int>(std::max_element(probabilities.begin(), probabilities.end()) -
                          probabilities.begin());
}

}  // namespace drill_pipe_pose
