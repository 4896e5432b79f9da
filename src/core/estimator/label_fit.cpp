#include "label_fit.hpp"

#include <algorithm>
#include <limits>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

#include "instance_fit.hpp"

namespace drill_pipe_pose {

namespace {

/// The clusters of a label's carved points (largest first) measured by at least
/// carving.min_cameras cameras (fewer when fewer have a box of the label): one camera that calls
/// the other end by this label does not make an instance.
std::vector<std::vector<size_t>> instanceClusters(const CycleContext& ctx, int l,
                                                  const std::vector<CloudPoint>& carved) {
  const EstimatorConfig& config = ctx.config;
  std::vector<std::vector<size_t>> clusters = euclideanClusters(
      carved, config.instances.cluster_tolerance, config.axis_fit.min_points);
  if (config.instances.split_at_support)
    clusters = splitAtSupport(carved, std::move(clusters), config.instances.cluster_tolerance,
                              config.axis_fit.min_points, 2 * ctx.models.joint_radius[l],
                              config.axis_fit);
  int with_label = 0;
  for (const auto& cam : ctx.cams) with_label += cam.has_label[l] ? 1 : 0;
  const size_t need = static_cast<size_t>(std::min(config.carving.min_cameras, with_label));
  std::vector<std::vector<size_t>> kept;
  for (auto& c : clusters) {
    std::set<uint16_t> seen;
    for (size_t i : c) seen.insert(carved[i].camera);
    if (seen.size() >= need) kept.push_back(std::move(c));
  }
  return kept;
}

/// The cluster a continuing track follows: the one with a point nearest its predicted origin,
/// within instances.track_gate; -1 when none.
int trackedCluster(const CycleContext& ctx, const Track& tr,
                   const std::vector<std::vector<size_t>>& clusters,
                   const std::vector<CloudPoint>& carved) {
  const EstimatorConfig& config = ctx.config;
  if (!tr.continues(ctx.stamp_ns, config.tracking.max_gap)) return -1;
  const Eigen::Vector3f pred =
      tr.predict(ctx.stamp_ns, config.tracking.max_prediction).cast<float>();
  size_t best_k = 0;
  float best_d2 = std::numeric_limits<float>::infinity();
  for (size_t k = 0; k < clusters.size(); ++k) {
    for (size_t i : clusters[k]) {
      const float d2 = (carved[i].p_world - pred).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best_k = k;
    }
  }
  const double gate = config.instances.track_gate;
  return best_d2 <= gate * gate ? static_cast<int>(best_k) : -1;
}

/// The clusters the label's other ends follow: (other end, cluster) pairs, each continuing
/// track paired with a cluster not `taken` that has a point within instances.track_gate of its
/// prediction, the nearest pairs first.
std::vector<std::pair<size_t, size_t>> followedClusters(
    const CycleContext& ctx, const std::vector<OtherEnd>& ends,
    const std::vector<std::vector<size_t>>& clusters, const std::vector<CloudPoint>& carved,
    std::vector<bool> taken) {
  const EstimatorConfig& config = ctx.config;
  const double gate = config.instances.track_gate;
  std::vector<std::tuple<float, size_t, size_t>> pairs;  // (squared distance, end, cluster)
  for (size_t s = 0; s < ends.size(); ++s) {
    const Track& tr = ends[s].track;
    if (!tr.continues(ctx.stamp_ns, config.tracking.max_gap)) continue;
    const Eigen::Vector3f pred =
        tr.predict(ctx.stamp_ns, config.tracking.max_prediction).cast<float>();
    for (size_t k = 0; k < clusters.size(); ++k) {
      if (taken[k]) continue;
      float d2 = std::numeric_limits<float>::infinity();
      for (size_t i : clusters[k]) d2 = std::min(d2, (carved[i].p_world - pred).squaredNorm());
      if (d2 <= gate * gate) pairs.emplace_back(d2, s, k);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<bool> paired(ends.size(), false);
  std::vector<std::pair<size_t, size_t>> out;
  for (const auto& [d2, s, k] : pairs) {
    if (paired[s] || taken[k]) continue;
    paired[s] = true;
    taken[k] = true;
    out.emplace_back(s, k);
  }
  std::sort(out.begin(), out.end());  // in the ends' order
  return out;
}

/// A fit of this label's model reversed against a decided instance of the label
/// (reversedAgainst) is that instance fitted flipped: *c becomes not ok, its reason says why.
void rejectFlipped(const CycleContext& ctx, int l, const std::vector<InstanceMemory>& memory,
                   Candidate* c) {
  const EstimatorConfig& config = ctx.config;
  const EndLabel detected = static_cast<EndLabel>(l);
  if (!c->ok || c->fit.label != detected) return;
  const InstanceMemory* e =
      reversedAgainst(c->fit.origin, c->fit.z, memory, ctx.stamp_ns, config.instances);
  if (!e) return;
  std::ostringstream s;
  s.precision(3);
  s << "axis reversed against the " << labelName(detected) << " instance at (" << e->origin.x()
    << ", " << e->origin.y() << ", " << e->origin.z() << "), " << (c->fit.origin - e->origin).norm()
    << " m away (decided " << e->decisions << " times; instances.reversal_reach = "
    << config.instances.reversal_reach << " m): that end fitted flipped, not taken";
  c->ok = false;
  c->reason = s.str();
}

/// The label's candidate among the instances decided this cycle (`inst`; [0] is the track's
/// when `tracked_first`): instances that fit this label's model compete, the other model's only
/// when none does (the label is then corrected).
Candidate chooseCandidate(const CycleContext& ctx, int l, std::vector<Candidate>& inst,
                          bool tracked_first, const std::vector<CloudPoint>& raw,
                          std::vector<InstanceMemory>* memory, int* chosen) {
  *chosen = -1;
  const EstimatorConfig& config = ctx.config;
  const EndLabel detected = static_cast<EndLabel>(l);
  for (Candidate& c : inst) rejectFlipped(ctx, l, *memory, &c);
  bool any_native = false;
  for (const Candidate& c : inst) any_native = any_native || (c.ok && c.fit.label == detected);
  std::vector<InstanceFit> fits(inst.size());
  for (size_t k = 0; k < inst.size(); ++k) {
    const Candidate& c = inst[k];
    fits[k] = {c.ok && (!any_native || c.fit.label == detected), c.fit.origin, c.fit.cost, {},
               c.fit.z};
    if (fits[k].competes && config.instances.radius_difference > 0)
      fits[k].radius = radiusOffset(ctx.models.models[static_cast<int>(c.fit.label)],
                                    ctx.models.joint_radius[static_cast<int>(c.fit.label)],
                                    c.fit.origin, c.fit.z, c.pts, c.eyes, c.fit.inlier_mask);
  }
  const InstanceChoice choice = chooseInstance(
      memory, fits, tracked_first ? 0 : -1, ctx.stamp_ns,
      [&](const Eigen::Vector3d& o, double radius) {
        const Eigen::Vector3f of = o.cast<float>();
        const float r2 = static_cast<float>(radius * radius);
        size_t near = 0;
        for (const auto& p : raw) near += (p.p_world - of).squaredNorm() <= r2 ? 1 : 0;
        return near;
      },
      config.axis_fit.min_points, config.instances, labelName(detected));
  if (choice.index >= 0) {
    *chosen = choice.index;
    return std::move(inst[static_cast<size_t>(choice.index)]);
  }
  Candidate cd;
  if (!choice.reason.empty()) {
    cd.detected = detected;
    cd.reason = choice.reason;
    return cd;
  }
  *chosen = 0;
  cd = std::move(inst[0]);
  if (inst.size() > 1)
    cd.reason = "no instance fits (" + std::to_string(inst.size()) + "); the first: " + cd.reason;
  return cd;
}

/// A cluster's points (indices into `carved`).
std::vector<CloudPoint> clusterPoints(const std::vector<size_t>& cluster,
                                      const std::vector<CloudPoint>& carved) {
  std::vector<CloudPoint> p;
  p.reserve(cluster.size());
  for (size_t i : cluster) p.push_back(carved[i]);
  return p;
}

/// In a cycle without a decision, new other ends: each cluster that no track follows (`taken`)
/// is fitted as a new end - a pipe laid down beside the tracked one, an end whose track was lost
/// while the label's own track went on - while the label has room for other ends. Not near a
/// cluster whose such fit failed within tracking.max_gap: clutter that never fits would be
/// refitted every cycle (the cluttered scene).
void startOtherEnds(const CycleContext& ctx, int l,
                    const std::vector<std::vector<size_t>>& clusters,
                    const std::vector<bool>& taken, const std::vector<CloudPoint>& carved,
                    LabelState* state, LabelTiming* timing, std::vector<OtherFit>* others) {
  const EstimatorConfig& config = ctx.config;
  auto& tries = state->failed_starts;
  const auto stale = [&](const std::pair<Eigen::Vector3d, int64_t>& t) {
    const double age = static_cast<double>(ctx.stamp_ns - t.second) * 1e-9;
    return !(age >= 0 && age <= config.tracking.max_gap);
  };
  tries.erase(std::remove_if(tries.begin(), tries.end(), stale), tries.end());
  const size_t room = 2 * static_cast<size_t>(config.instances.max_other_ends);
  for (size_t k = 0; k < clusters.size(); ++k) {
    if (taken[k]) continue;
    if (state->others.size() + others->size() >= room) break;
    std::vector<CloudPoint> pts = clusterPoints(clusters[k], carved);
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const CloudPoint& p : pts) centroid += p.p_world.cast<double>();
    centroid /= static_cast<double>(pts.size());
    bool tried = false;
    for (const auto& t : tries)
      tried = tried || (t.first - centroid).norm() <= config.instances.track_gate;
    if (tried) continue;
    Candidate c = InstanceFitter(ctx, l, pts).fit(Track(), false, timing);
    rejectFlipped(ctx, l, state->memory, &c);
    if (c.ok && static_cast<int>(c.fit.label) == l)
      others->push_back({-1, std::move(c)});
    else
      tries.emplace_back(centroid, ctx.stamp_ns);
  }
}

}  // namespace

Candidate fitLabel(const CycleContext& ctx, int l, const std::vector<CloudPoint>& raw,
                   const std::vector<CloudPoint>& carved, LabelState* state, LabelTiming* timing,
                   uint32_t* instances, std::vector<OtherFit>* others) {
  const EstimatorConfig& config = ctx.config;
  Candidate cd;
  cd.detected = static_cast<EndLabel>(l);
  bool any_box = false;
  for (const auto& cam : ctx.cams) any_box = any_box || cam.has_label[l];
  if (!any_box) {
    cd.reason = std::string("no ") + labelName(cd.detected) + " detection in any camera";
    return cd;
  }
  if (carved.size() < config.axis_fit.min_points) {
    std::ostringstream s;
    s << raw.size() << " points cut out, " << carved.size()
      << " after carving (< axis_fit.min_points = " << config.axis_fit.min_points << ")";
    cd.reason = s.str();
    return cd;
  }
  const auto t0 = Clock::now();
  const std::vector<std::vector<size_t>> clusters = instanceClusters(ctx, l, carved);
  auto pointsOf = [&](size_t k) { return clusterPoints(clusters[k], carved); };
  timing->segmentation_ms += msSince(t0);
  *instances = static_cast<uint32_t>(clusters.size());
  if (clusters.empty()) {
    std::ostringstream s;
    s << carved.size() << " points after carving, no cluster of axis_fit.min_points = "
      << config.axis_fit.min_points << " from carving.min_cameras = "
      << config.carving.min_cameras << " cameras (instances.cluster_tolerance = "
      << config.instances.cluster_tolerance << " m)";
    cd.reason = s.str();
    return cd;
  }
  const int track_k = trackedCluster(ctx, state->track, clusters, carved);
  // The label's other ends: each continuing track follows a cluster not yet taken, the nearest
  // (track, cluster) pairs first, so that a track whose own cluster is missing this cycle does
  // not take its neighbour's before the neighbour's track does.
  std::vector<bool> taken(clusters.size(), false);
  if (track_k >= 0) taken[static_cast<size_t>(track_k)] = true;
  std::vector<bool> reported(clusters.size(), false);  // an other end's fit of it was accepted
  for (const auto& [s, k] : followedClusters(ctx, state->others, clusters, carved, taken)) {
    taken[k] = true;
    // An other end of a type of its own is fitted with that type's models.
    const int type = state->others[s].type;
    const EndModels* own = ctx.type_models && type >= 0 &&
                                   static_cast<size_t>(type) < ctx.type_models->size()
                               ? (*ctx.type_models)[static_cast<size_t>(type)]
                               : nullptr;
    const CycleContext typed{ctx.config, own ? *own : ctx.models, ctx.cams, ctx.stamp_ns,
                             ctx.box_decides, ctx.type_models};
    others->push_back({static_cast<int>(s), InstanceFitter(typed, l, pointsOf(k))
                                                .fit(state->others[s].track, true, timing)});
    if (!others->back().cd.tracked) rejectFlipped(ctx, l, state->memory, &others->back().cd);
    reported[k] = others->back().cd.ok;
  }
  // The instances decided this cycle: the track's (when its fit is not simply tracked: a
  // periodic decision, or the track was lost) and the largest others (those the other ends
  // follow too: the label's choice is the same with other ends in view or not).
  std::vector<Candidate> inst;
  if (track_k >= 0) {
    Candidate c = InstanceFitter(ctx, l, pointsOf(static_cast<size_t>(track_k)))
                      .fit(state->track, true, timing);
    if (c.tracked) {
      startOtherEnds(ctx, l, clusters, taken, carved, state, timing, others);
      return c;
    }
    inst.push_back(std::move(c));
  }
  const size_t max_instances = static_cast<size_t>(config.instances.max_instances);
  std::vector<size_t> inst_cluster;  // the cluster of each decided instance
  if (track_k >= 0) inst_cluster.push_back(static_cast<size_t>(track_k));
  for (size_t k = 0; k < clusters.size() && inst.size() < max_instances; ++k) {
    if (static_cast<int>(k) == track_k) continue;
    inst.push_back(InstanceFitter(ctx, l, pointsOf(k)).fit(state->track, false, timing));
    inst_cluster.push_back(k);
  }
  int chosen = -1;
  cd = chooseCandidate(ctx, l, inst, track_k >= 0, raw, &state->memory, &chosen);
  // The decision's other valid fits of this label's model start ends of their own, except on a
  // cluster whose other end's fit was accepted this cycle: one cluster is one end, and the
  // decision's fit of it may lie elsewhere along the axis (beyond instances.track_gate, where
  // outputOthers would not see it as the same end: a second end 0.27 m along a lying pipe's
  // axis from its true one, catwalk_twin seed 120).
  const size_t max_others = static_cast<size_t>(config.instances.max_other_ends);
  for (size_t k = 0; k < inst.size(); ++k)
    if (static_cast<int>(k) != chosen && inst[k].ok && static_cast<int>(inst[k].fit.label) == l &&
        !reported[inst_cluster[k]] && state->others.size() + others->size() < 2 * max_others)
      others->push_back({-1, std::move(inst[k])});
  return cd;
}

}  // namespace drill_pipe_pose
