// Type trials: an end refitted with each candidate type's model (type_trial.hpp).

#include "type_trial.hpp"

#include <algorithm>


namespace drill_pipe_pose {

const ProfileModel& TypeModelCache::at(int slot, int type) {
  const std::pair<int, int> key{slot, type};
  auto it = models_.find(key);
  if (it == models_.end())
    it = models_.emplace(key, ProfileModel(static_cast<EndLabel>(slot), candidates_[type].dims))
             .first;
  return it->second;
}

std::vector<TypeTrial> runTypeTrials(int slot, const Candidate& cd, const std::vector<int>& types,
                                     const EstimatorConfig& config, TypeModelCache* models) {
  // The points the pose refinement uses (those clear of a level support), subsampled as the
  // coarse stages are, with the refinement's full iterations: every point made the trials cost
  // as much as the rest of the cycle on the cluttered scene (its tracks restart often), and the
  // trials are averaged along the track anyway (nextType).
  std::vector<size_t> idx;
  const float z_clear = cd.support_z + static_cast<float>(config.profile_fit.support_clearance);
  for (size_t i = 0; i < cd.pts.size(); ++i)
    if (!cd.has_support || cd.pts[i].z() >= z_clear) idx.push_back(i);
  if (idx.size() < config.axis_fit.min_points) {
    idx.resize(cd.pts.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  }
  const size_t n = std::max<size_t>(1, config.profile_fit.coarse_points);
  const size_t stride = std::max<size_t>(1, (idx.size() + n - 1) / n);
  std::vector<Eigen::Vector3f> pts, eyes;
  std::vector<float> sig;
  for (size_t j = 0; j < idx.size(); j += stride) {
    pts.push_back(cd.pts[idx[j]]);
    eyes.push_back(cd.eyes[idx[j]]);
    sig.push_back(cd.sigmas[idx[j]]);
  }
  std::vector<TypeTrial> out;
  for (int type : types) {
    TypeTrial t;
    t.type = type;
    const ProfileModel& model = models->at(slot, type);
    const ProfileFitResult f =
        refineProfile(pts, sig, cd.fit.origin, cd.fit.z, model, config.profile_fit,
                      config.profile_fit.iterations, false, &eyes);
    if (f.ok) {
      const RadiusCheck rc = radiusOffset(model, models->candidate(type).dims.tool_joint_od / 2, f.origin, f.z,
                                          pts, eyes, f.inlier_mask);
      t.ok = rc.ok;
      t.offset = rc.offset;
    }
    out.push_back(t);
  }
  return out;
}

}  // namespace drill_pipe_pose
