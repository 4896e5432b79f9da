#pragma once
// Type trials (private to the estimator's sources): an end refitted with another pipe type's
// model from its current pose, and its joint's radius measured against that model
// (pipe_type.hpp says how a trial is chosen).

#include <map>
#include <utility>
#include <vector>

#include "candidate.hpp"
#include "drill_pipe_pose/core/estimator/pipe_type.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"

namespace drill_pipe_pose {

/// The profile model of each (end, candidate type), built on first use.
class TypeModelCache {
 public:
  explicit TypeModelCache(const std::vector<PipeCandidate>& candidates)
      : candidates_(candidates) {}
  const ProfileModel& at(int slot, int type);
  const PipeCandidate& candidate(int type) const { return candidates_[type]; }

 private:
  const std::vector<PipeCandidate>& candidates_;
  std::map<std::pair<int, int>, ProfileModel> models_;
};

/// End `slot`'s candidate `cd` refitted with each type of `types` (profile_fit.coarse_points of
/// its points above its support, profile_fit.hypothesis_iterations from its fit), and the
/// joint's radius measured against each (radiusOffset).
std::vector<TypeTrial> runTypeTrials(int slot, const Candidate& cd, const std::vector<int>& types,
                                     const EstimatorConfig& config, TypeModelCache* models);

}  // namespace drill_pipe_pose
