#pragma once
// The radius search (private to the estimator's sources): an end refitted with models of other
// tool-joint radii until one explains its points (searchRadius in pipe_type.hpp), so that a
// joint's radius is measured, not read off the model it happens to be fitted with.

#include <cstdint>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "candidate.hpp"
#include "drill_pipe_pose/core/estimator/pipe_type.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"

namespace drill_pipe_pose {

/// Profile models of any joint radius, built on first use.
class RadiusModelCache {
 public:
  explicit RadiusModelCache(const std::vector<PipeCandidate>& candidates)
      : candidates_(candidates) {}
  const PipeCandidate& candidate(int type) const { return candidates_[type]; }
  const std::vector<PipeCandidate>& candidates() const { return candidates_; }
  /// The model of end `slot` whose joint radius is `radius` [m] (rounded to 0.25 mm: *radius
  /// receives the model's), with the rest of the geometry of the candidate whose joint is
  /// nearest in size; null when that geometry does not hold (a joint too thin for its pin).
  const ProfileModel* at(int slot, double* radius);

 private:
  /// Models kept at most: the searches of both ends' decisions reuse about 20.
  static constexpr size_t kMaxModels = 32;
  struct Entry {
    std::unique_ptr<ProfileModel> model;  ///< null: that geometry does not hold
    uint64_t last_use = 0;
  };
  const std::vector<PipeCandidate>& candidates_;
  std::map<std::pair<int, long>, Entry> models_;
  uint64_t uses_ = 0;
};

/// End `slot`'s tool-joint radius measured from its candidate `cd` fitted with type `type`
/// (searchRadius from that type's radius, within 10 mm of the candidates' thinnest and
/// thickest joints): the points clear of a level support, subsampled to
/// profile_fit.coarse_points, refitted (refineProfile, profile_fit.iterations) with the model of
/// each radius the search asks for, each from the last refit's pose, and the joint's radius
/// measured against it (radiusOffset).
RadiusSearch measureJointRadius(int slot, const Candidate& cd, int type,
                                const EstimatorConfig& config, RadiusModelCache* models);

}  // namespace drill_pipe_pose
