// The radius search: an end refitted with models of other joint radii (radius_search.hpp).

#include "radius_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

const ProfileModel* RadiusModelCache::at(int slot, double* radius) {
  constexpr double kStep = 0.00025;  // [m] radii this close share a model
  const long q = std::lround(*radius / kStep);
  *radius = static_cast<double>(q) * kStep;
  const std::pair<int, long> key{slot, q};
  ++uses_;
  auto it = models_.find(key);
  if (it != models_.end()) {
    it->second.last_use = uses_;
    return it->second.model.get();
  }
  // A search visits a handful of radii per decision, most of them again at the next; over a
  // run it visits many more (52 models, 12 MB, in 4 s of thesis_vertical, seed 1): the least
  // recently used model goes (a model is about 0.2 MB).
  if (models_.size() >= kMaxModels) {
    auto oldest = models_.begin();
    for (auto m = models_.begin(); m != models_.end(); ++m)
      if (m->second.last_use < oldest->second.last_use) oldest = m;
    models_.erase(oldest);
  }
  size_t nearest = 0;
  for (size_t k = 1; k < candidates_.size(); ++k)
    if (std::abs(candidates_[k].dims.tool_joint_od - 2 * *radius) <
        std::abs(candidates_[nearest].dims.tool_joint_od - 2 * *radius))
      nearest = k;
  std::unique_ptr<ProfileModel> model;
  if (!candidates_.empty()) {
    ToolJointDimensions dims = candidates_[nearest].dims;
    dims.tool_joint_od = 2 * *radius;
    try {
      model = std::make_unique<ProfileModel>(static_cast<EndLabel>(slot), dims);
    } catch (const InputError&) {
      model.reset();  // the nearest type's pin or bore does not fit inside this joint
    }
  }
  Entry& e = models_[key];
  e.model = std::move(model);
  e.last_use = uses_;
  return e.model.get();
}

namespace {

/// The points of `cd` a search refits: those clear of a level support, subsampled to about
/// profile_fit.coarse_points.
void searchPoints(const Candidate& cd, const EstimatorConfig& config,
                  std::vector<Eigen::Vector3f>* pts, std::vector<Eigen::Vector3f>* eyes,
                  std::vector<float>* sig) {
  // The points the pose refinement uses (those clear of a level support), subsampled as the
  // coarse stages are, with the refinement's full iterations: every point made the refits cost
  // as much as the rest of the cycle on the cluttered scene (its tracks restart often), and the
  // searched radii are averaged along the track anyway (nextType).
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
  for (size_t j = 0; j < idx.size(); j += stride) {
    pts->push_back(cd.pts[idx[j]]);
    eyes->push_back(cd.eyes[idx[j]]);
    sig->push_back(cd.sigmas[idx[j]]);
  }
}

}  // namespace

RadiusSearch measureJointRadius(int slot, const Candidate& cd, int type,
                                const EstimatorConfig& config, RadiusModelCache* models) {
  std::vector<Eigen::Vector3f> pts, eyes;
  std::vector<float> sig;
  searchPoints(cd, config, &pts, &eyes, &sig);
  double r_min = std::numeric_limits<double>::infinity(), r_max = 0.0;
  for (const PipeCandidate& c : models->candidates()) {
    r_min = std::min(r_min, c.dims.tool_joint_od / 2);
    r_max = std::max(r_max, c.dims.tool_joint_od / 2);
  }
  // [m] beyond the catalogue's thinnest and thickest joints: a reading there is off the
  // catalogue, and says so, rather than stopping at its end.
  constexpr double kBeyond = 0.01;
  Eigen::Vector3d origin = cd.fit.origin, z = cd.fit.z;
  const auto offset_at = [&](double r_asked, double* offset, double* std) {
    double r = r_asked;
    const ProfileModel* model = models->at(slot, &r);
    if (!model) return false;
    const ProfileFitResult f = refineProfile(pts, sig, origin, z, *model, config.profile_fit,
                                             config.profile_fit.iterations, false, &eyes);
    if (!f.ok) return false;
    const RadiusCheck rc = radiusOffset(*model, r, f.origin, f.z, pts, eyes, f.inlier_mask);
    if (!rc.ok) return false;
    origin = f.origin;
    z = f.z;
    *offset = rc.offset + (r - r_asked);  // from the radius asked for, not the model's rounded one
    *std = rc.std;
    return true;
  };
  return searchRadius(offset_at, models->candidate(type).dims.tool_joint_od / 2,
                      r_min - kBeyond, r_max + kBeyond);
}

}  // namespace drill_pipe_pose
