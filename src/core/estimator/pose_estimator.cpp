// The estimator's cycle as a sequence of named stages: input assembly, cut-out, carving,
// instances (per label: axis fit, hypotheses and decision, refinement), label corrections,
// tracking, assignment of candidates to ends, temporal filter, covariance, output; around them
// the drift watch (drift_watch.hpp): flagged cameras left out before the cut-out, every camera
// measured against the fitted ends after the output; and each end's pipe type (pipe_type.hpp),
// whose model the next cycles fit.

#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "candidate.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/carving.hpp"
#include "drill_pipe_pose/core/estimator/covariance.hpp"
#include "drill_pipe_pose/core/estimator/temporal_filter.hpp"
#include "drill_pipe_pose/core/estimator/thesis_baseline.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "end_models.hpp"
#include "label_fit.hpp"
#include "radius_search.hpp"

namespace drill_pipe_pose {

/// One published end's pipe type across cycles (pipe_type.hpp).
struct EndType {
  int type = 0;            ///< index into the candidates: the model the end is fitted with
  TypeEvidence evidence;   ///< the measurements on the end's track (against its type's model)
  /// The joint radii searched for at the track's decisions (measureJointRadius): absolute, so
  /// they hold across type changes.
  SearchedRadii measured;
  int decisions = 0;  ///< its decisions since its searched radii were sure (searchDue)
  int64_t last_valid_ns = 0;  ///< capture stamp of the end's last valid cycle
  uint32_t id = 0;            ///< the end's instance id (0: no track)
  Eigen::Vector3d last_origin = Eigen::Vector3d::Zero();  ///< [m] of its last valid fit
  /// The id went with the end to an other end while this one had no pose (outputOthers): a
  /// later fit elsewhere is another end all the same (its evidence restarts).
  bool handed_off = false;
  /// The id of the end this one left (its fit moved to another end), for that end's next fit
  /// as an other end within tracking.max_gap: (id, its last origin [m], capture stamp).
  uint32_t released_id = 0;
  Eigen::Vector3d released_origin = Eigen::Vector3d::Zero();
  int64_t released_ns = 0;
};

/// Everything that lives across cycles, in one place (reset() clears it).
struct EstimatorState {
  std::array<LabelState, kNumEnds> labels;  ///< per detected label
  std::array<EndPoseFilter, kNumEnds> filters;  ///< per published end
  std::array<EndType, kNumEnds> types;          ///< per published end
  uint32_t next_id = 1;                         ///< the next instance id
  std::unique_ptr<ThesisBaseline> baseline;     ///< with method thesis_baseline
  DriftWatch drift;                             ///< per camera (EstimatorConfig::Drift)
  /// Per published end, its last valid pose and that cycle's stamp (0: none yet).
  std::array<Eigen::Isometry3d, kNumEnds> last_pose{
      {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()}};
  std::array<int64_t, kNumEnds> last_pose_ns{{0, 0}};
};

/// The pipe types an end may take: the resolved candidates, or the one type of config.dims.
std::vector<PipeCandidate> candidatesOf(const EstimatorConfig& config) {
  if (!config.candidates.empty()) return config.candidates;
  return {{config.pipe_type.empty() ? std::string("configured") : config.pipe_type, config.dims}};
}

/// The index of the candidate the models start from: pipe_type's, else 0.
int startType(const EstimatorConfig& config, const std::vector<PipeCandidate>& cands) {
  for (size_t k = 0; k < cands.size(); ++k)
    if (cands[k].name == config.pipe_type) return static_cast<int>(k);
  return 0;
}

struct PoseEstimator::Impl {
  explicit Impl(const EstimatorConfig& config)
      : candidates(candidatesOf(config)), start(startType(config, candidates)),
        radius_models(candidates) {
    for (auto& t : state.types) t.type = start;
  }
  /// The models of the ends' current types (built once per pair of types).
  const EndModels& models(const EstimatorConfig& config) {
    return modelsOf(config, state.types[0].type, state.types[1].type);
  }
  /// The models of a box end of type `box` and a pin end of type `pin`.
  const EndModels& modelsOf(const EstimatorConfig& config, int box, int pin) {
    const std::pair<int, int> key{box, pin};
    auto it = model_sets.find(key);
    if (it == model_sets.end())
      it = model_sets
               .emplace(key, std::make_unique<EndModels>(config, candidates[key.first].dims,
                                                         candidates[key.second].dims))
               .first;
    return *it->second;
  }
  const std::vector<PipeCandidate> candidates;
  const int start;  ///< the type every end starts from
  RadiusModelCache radius_models;  ///< models of any joint radius, for the radius search
  std::map<std::pair<int, int>, std::unique_ptr<EndModels>> model_sets;
  EstimatorState state;
  /// The configuration with profile_fit.reflectivity 0 (the cycles whose frames carry their
  /// amplitude), made on first use.
  const EstimatorConfig& withoutPredictedBias(const EstimatorConfig& config) {
    if (!measured_config) {
      measured_config = std::make_unique<EstimatorConfig>(config);
      measured_config->profile_fit.reflectivity = 0.0;
    }
    return *measured_config;
  }
  std::unique_ptr<EstimatorConfig> measured_config;
};

namespace {

/// Stage "input assembly": each camera's input validated into a CycleCamera; a bad one is
/// skipped and named in result->camera_errors, a good one in result->cameras_used.
std::vector<CycleCamera> assembleCameras(const std::vector<CameraInput>& inputs,
                                         float min_confidence, CycleResult* result) {
  std::vector<CycleCamera> cams;
  cams.reserve(inputs.size());
  for (const CameraInput& in : inputs) {
    try {
      cams.push_back(
          makeCycleCamera(in.frame, in.T_world_depth, in.T_color_depth, min_confidence,
                          in.depth_correction));
      result->cameras_used.push_back(in.frame.camera);
    } catch (const InputError& e) {
      result->camera_errors.push_back(e.what());
    }
  }
  return cams;
}

/// Stage "drift watch" before the fit: the flagged cameras whose points leave this cycle's fit
/// (drift.leave_out), the most disagreeing first, while drift.min_cameras others remain; moved
/// from `cams` into the returned list.
std::vector<CycleCamera> takeLeftOut(std::vector<CycleCamera>* cams, const DriftWatch& watch,
                                     const EstimatorConfig::Drift& dc) {
  std::vector<CycleCamera> out;
  if (!dc.enabled || !dc.leave_out) return out;
  std::vector<std::pair<double, size_t>> flagged;  // (-excess, index): most disagreeing first
  for (size_t c = 0; c < cams->size(); ++c)
    if (watch.flagged((*cams)[c].name)) flagged.emplace_back(-watch.excess((*cams)[c].name), c);
  if (flagged.empty()) return out;
  std::sort(flagged.begin(), flagged.end());
  std::vector<bool> leave(cams->size(), false);
  int remaining = static_cast<int>(cams->size());
  for (const auto& f : flagged) {
    if (remaining - 1 < dc.min_cameras) break;
    leave[f.second] = true;
    --remaining;
  }
  std::vector<CycleCamera> kept;
  for (size_t c = 0; c < cams->size(); ++c)
    (leave[c] ? out : kept).push_back(std::move((*cams)[c]));
  *cams = std::move(kept);
  return out;
}

/// Stage "drift watch" after the output: each camera's cut-out points of a valid end's label
/// (the fit's cameras' from `raw`; the left-out cameras' cut out here, indexed after them)
/// against that end's fitted model; the watch updated, and its status into result->drift.
void watchDrift(const std::vector<CycleCamera>& cams, const std::vector<CycleCamera>& left_out,
                const std::array<std::vector<CloudPoint>, kNumEnds>& raw,
                const std::array<Candidate, kNumEnds>& cand, const std::array<int, kNumEnds>& owner,
                const EndModels& models, int64_t stamp_ns, const EstimatorConfig& config,
                DriftWatch* watch, CycleResult* result) {
  std::array<std::vector<CloudPoint>, kNumEnds> raw_out;
  for (size_t k = 0; k < left_out.size(); ++k)
    cutOutCamera(left_out[k], static_cast<uint16_t>(cams.size() + k), config, &raw_out);
  auto camAt = [&](size_t c) -> const CycleCamera& {
    return c < cams.size() ? cams[c] : left_out[c - cams.size()];
  };
  const size_t n = cams.size() + left_out.size();
  DriftObservations obs;
  for (int slot = 0; slot < kNumEnds; ++slot) {
    if (!result->ends[slot].valid || owner[slot] < 0) continue;
    const Candidate& cd = cand[owner[slot]];
    FittedSurface s;
    s.model = &models.models[slot];
    s.origin = cd.fit.origin;
    s.z = cd.fit.z;
    s.min_z = s.model->trustedMinZ(config.profile_fit.wear_margin);
    if (cd.has_support) s.min_world_z = cd.support_z + config.profile_fit.support_clearance;
    std::vector<std::vector<Eigen::Vector3f>> per(n);
    const std::array<const std::vector<CloudPoint>*, 2> sources{{&raw[owner[slot]],
                                                                 &raw_out[owner[slot]]}};
    for (const std::vector<CloudPoint>* pts : sources)
      for (const CloudPoint& p : *pts) per[p.camera].push_back(p.p_world);
    for (size_t c = 0; c < n; ++c)
      obs[camAt(c).name][slot] =
          observeShift(per[c], camAt(c).T_world_depth.translation(), s, config.drift.gate);
  }
  watch->updateByEnd(stamp_ns, obs);
  result->drift = watch->status();
  for (CameraDriftStatus& d : result->drift)
    for (const CycleCamera& cam : left_out) d.left_out = d.left_out || cam.name == d.camera;
}

/// Whether a full decision is planned for the box end's label this cycle: it has a box, and no
/// continuing track, or its periodic decision is due.
bool boxDecides(const std::vector<CycleCamera>& cams, const Track& box_track, int64_t stamp_ns,
                const EstimatorConfig::Tracking& trc) {
  bool any = false;
  for (const auto& cam : cams) any = any || cam.has_label[0];
  return any && !(box_track.continues(stamp_ns, trc.max_gap) &&
                  box_track.cycles < trc.redecide_every);
}

/// Stage "label corrections": a decision whose fit takes the other model while the label's last
/// valid fit (within tracking.max_gap) took its own - one cycle of a dark joint whose cone drops
/// out, say - is not published until instances.min_decisions decisions in a row say so; its
/// track, if any, goes on meanwhile. A label with no recent fit of its own model is corrected at
/// once (a detector that swaps the labels in every camera). Returns which labels were held.
std::array<bool, kNumEnds> holdLabelFlips(std::array<Candidate, kNumEnds>* cand,
                                          std::array<LabelState, kNumEnds>* labels,
                                          int64_t stamp_ns, const EstimatorConfig& config) {
  std::array<bool, kNumEnds> held{{false, false}};
  for (int l = 0; l < kNumEnds; ++l) {
    Candidate& cd = (*cand)[l];
    LabelState& ls = (*labels)[l];
    if (!cd.ok || cd.tracked) continue;
    if (static_cast<int>(cd.fit.label) == l) {
      ls.flips = 0;
      continue;
    }
    if (!(ls.track.recent(stamp_ns, config.tracking.max_gap) &&
          static_cast<int>(ls.track.model) == l))
      continue;
    if (++ls.flips >= config.instances.min_decisions) continue;
    std::ostringstream s;
    s << "the " << labelName(cd.detected) << " detections fit the " << labelName(cd.fit.label)
      << " model in this decision, against their last fit (" << ls.flips << " of "
      << config.instances.min_decisions << " decisions in a row needed to correct the label)";
    cd.ok = false;
    cd.reason = s.str();
    held[l] = true;
  }
  return held;
}

/// Stage "tracking": each label's track follows its valid fit; a label without one (and not
/// held by holdLabelFlips) ends its track.
void updateTracks(const std::array<Candidate, kNumEnds>& cand,
                  const std::array<bool, kNumEnds>& held, std::array<LabelState, kNumEnds>* labels,
                  int64_t stamp_ns, const EstimatorConfig::Tracking& trc) {
  for (int l = 0; l < kNumEnds; ++l) {
    Track& tr = (*labels)[l].track;
    const Candidate& cd = cand[l];
    if (held[l]) continue;
    if (!cd.ok) {
      tr.end();
      continue;
    }
    tr.follow(stamp_ns,
              {cd.fit.label, cd.fit.origin, cd.fit.z, cd.tracked, cd.direction_margin,
               cd.has_support, cd.support_z},
              trc.max_gap, trc.max_offset);
  }
}

/// Whether a label's candidate `own` was fitted, but failed (a registration that converged, then was
/// gated: a joint of another size fitted with this type's models) more than `gate` from
/// `origin`: the detector saw that end there, so a fit at `origin` is another end. Whichever
/// model its fit took: a 3-1/2" NC38 box end whose own fit took the pin model and failed let the
/// pin end's fit of the box model be published as the box end, 1.48 m from it, for 3 cycles
/// (thesis_vertical, seed 200).
bool ownFitFailedElsewhere(const Candidate& own, const Eigen::Vector3d& origin, double gate) {
  return !own.ok && own.fit.ok && (own.fit.origin - origin).norm() > gate;
}

/// Stage "assignment": the end each valid candidate stands for is the model that fits it; when
/// both candidates fit one model, the detected label wins, then the lower cost. A candidate
/// whose label is corrected does not take an end whose own detections were fitted elsewhere and
/// failed (ownFitFailedElsewhere): on a 6-5/8" FH joint, while the 5" NC50 model is still
/// configured, the pin end's pin reads as an NC50 box end and was published as the box end,
/// 1.5 m from it, for the first 1.3 s (thesis_vertical, seed 93). Per end, the index of its
/// candidate's label, or -1.
std::array<int, kNumEnds> assignEnds(const std::array<Candidate, kNumEnds>& cand,
                                     double gate) {
  std::array<int, kNumEnds> owner{{-1, -1}};
  for (int l = 0; l < kNumEnds; ++l) {
    if (!cand[l].ok) continue;
    const int slot = static_cast<int>(cand[l].fit.label);
    if (slot != l && ownFitFailedElsewhere(cand[slot], cand[l].fit.origin, gate)) continue;
    const int prev = owner[slot];
    if (prev < 0) {
      owner[slot] = l;
    } else {
      const bool prev_native = static_cast<int>(cand[prev].detected) == slot;
      const bool this_native = l == slot;
      if (this_native && !prev_native)
        owner[slot] = l;
      else if (this_native == prev_native && cand[l].fit.cost < cand[prev].fit.cost)
        owner[slot] = l;
    }
  }
  return owner;
}

/// Why end `slot` has no pose: its own label's candidate failed, or fitted the other model.
std::string noPoseReason(int slot, const std::array<Candidate, kNumEnds>& cand, double gate) {
  const Candidate& own = cand[slot];
  const Candidate& other = cand[1 - slot];
  if (own.ok && static_cast<int>(own.fit.label) != slot)
    return std::string("the ") + labelName(static_cast<EndLabel>(slot)) + " detections fit the " +
           labelName(own.fit.label) + " model (label corrected)";
  if (own.ok) return "duplicate of another end";
  if (other.ok && static_cast<int>(other.fit.label) == slot &&
      ownFitFailedElsewhere(own, other.fit.origin, gate)) {
    std::ostringstream s;
    s.precision(3);
    s << own.reason << "; the " << labelName(static_cast<EndLabel>(1 - slot))
      << " detections fit the " << labelName(static_cast<EndLabel>(slot)) << " model "
      << (other.fit.origin - own.fit.origin).norm()
      << " m away: another end (instances.track_gate = " << gate << " m), not taken";
    return s.str();
  }
  return own.reason;
}

/// Stage "temporal filter" for a valid end: filtered in place; false (with the end made
/// invalid and its reason set) when the filter holds this cycle's pose back.
bool filterEnd(EndPoseFilter* filter, int64_t stamp_ns, const EstimatorConfig::Temporal& tc,
               EndEstimate* e) {
  Eigen::Vector3d o = e->T_world_end.translation(), z = e->T_world_end.linear().col(2);
  const FilterUpdate update = filter->update(stamp_ns, &o, &z, &e->covariance);
  if (update == FilterUpdate::kHeld || update == FilterUpdate::kStarting) {
    // One fit far from the end's filtered track (a wild fit, or the pipe moved), or a new
    // track's first: not published until the next agrees (temporal.confirmations).
    std::ostringstream s;
    s.precision(3);
    if (update == FilterUpdate::kStarting)
      s << "held: a new track's first pose (temporal.confirm_start)";
    else
      s << "held: this cycle's pose lies " << filter->lastPositionSigma() << " sigma and "
        << filter->lastTilt() * 180 / M_PI << " deg (gate " << filter->lastTiltGate() * 180 / M_PI
        << ") from the end's filtered track (temporal.gate_sigma = " << tc.gate_sigma << ")";
    s << "; published when temporal.confirmations = " << tc.confirmations << " more agree";
    const EndLabel label = e->label;
    *e = EndEstimate();
    e->label = label;
    e->reason = s.str();
    return false;
  }
  e->T_world_end = canonicalPose(o, z);
  return true;
}

/// What the rig calibration's share of an end's covariance depends on (calibrationCovariance).
struct EndSupport {
  std::set<uint16_t> cameras;  ///< cameras with inlier points
  double range_sum = 0;        ///< [m] their summed distance to the end
  double extent = 0;           ///< [m] the inliers' extent along the axis
  void addTo(EndEstimate* e, const EstimatorConfig& config) const {
    if (!cameras.empty())
      e->covariance += calibrationCovariance(e->T_world_end.linear().col(2), cameras.size(),
                                             range_sum / cameras.size(), extent,
                                             config.covariance);
  }
};

/// The pose of candidate `cd` into `e` (valid) with its fit's covariance, inlier points and
/// cameras; the inliers into `segmented` when given.
EndSupport fillEnd(int slot, const Candidate& cd, const std::vector<CycleCamera>& cams,
                   const EstimatorConfig& config, EndEstimate* e,
                   std::vector<Eigen::Vector3f>* segmented) {
  e->label = static_cast<EndLabel>(slot);
  e->valid = true;
  e->reason.clear();
  e->label_corrected = static_cast<int>(cd.detected) != slot;
  e->tracked = cd.tracked;
  e->T_world_end = canonicalPose(cd.fit.origin, cd.fit.z);
  e->covariance = worldCovariance(cd.fit, config.covariance);
  e->residual = cd.fit.rms;
  e->points = cd.fit.inliers;
  EndSupport sup;
  double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo;
  for (size_t i = 0; i < cd.pts.size(); ++i)
    if (cd.fit.inlier_mask[i]) {
      sup.cameras.insert(cd.cams[i]);
      if (segmented) segmented->push_back(cd.pts[i]);
      const double zi = (cd.pts[i].cast<double>() - cd.fit.origin).dot(cd.fit.z);
      z_lo = std::min(z_lo, zi);
      z_hi = std::max(z_hi, zi);
    }
  for (uint16_t c : sup.cameras) {
    e->cameras.push_back(cams[c].name);
    sup.range_sum += (cams[c].T_world_depth.translation() - cd.fit.origin).norm();
  }
  sup.extent = z_hi - z_lo;
  return sup;
}

/// Stage "output" for end `slot`: the pose of its candidate `cd` (null: none, explained from
/// `cand`) with its covariance, inlier points and cameras (fillEnd); the temporal filter
/// (filter, when temporal.enabled); then the rig calibration's share of the covariance, which
/// no filter reduces.
void outputEnd(int slot, const Candidate* cd, const std::array<Candidate, kNumEnds>& cand,
               const std::vector<CycleCamera>& cams, int64_t stamp_ns, EndPoseFilter* filter,
               const EstimatorConfig& config, CycleResult* result) {
  EndEstimate& e = result->ends[slot];
  if (!cd) {
    e.reason = noPoseReason(slot, cand, config.instances.track_gate);
    return;
  }
  const EndSupport sup = fillEnd(slot, *cd, cams, config, &e, &result->segmented[slot]);
  if (config.temporal.enabled && !filterEnd(filter, stamp_ns, config.temporal, &e)) return;
  sup.addTo(&e, config);
}

/// The probability of each candidate on an end's searched radii `own_radii`. A connection is made
/// up within one type, and a pipe's two ends are one type: while an end's own radii are not
/// sure of a joint OD (typing.switch_probability), its partner's (pairedRadii, coaxialPartner)
/// count too. A pin end lying on the catwalk reads its radius 65-100 mm for a true 84 mm, its
/// box end 81-85 mm (seed 92); two pipes of two sizes each read their own.
std::vector<double> searchedProbabilities(const RadiusMean& own_radii, const RadiusMean* partner,
                                          const std::vector<PipeCandidate>& cands,
                                          const TypingConfig& tc) {
  const std::vector<double> own = radiusProbabilities({&own_radii}, cands, tc);
  if (!partner || partner->count() < static_cast<size_t>(std::max(1, tc.min_measurements)) ||
      jointOdProbability(own, cands, topType(own)) >= tc.switch_probability)
    return own;
  return radiusProbabilities({&own_radii, partner}, cands, tc);
}

/// The joint radius of an end of label `slot` fitted (cd) with type `type`, searched for
/// (measureJointRadius) and added to its track's searched radii.
void searchJointRadius(int slot, const Candidate& cd, int type, const EstimatorConfig& config,
                       RadiusModelCache* radius_models, RadiusMean* measured) {
  const RadiusSearch rs = measureJointRadius(slot, cd, type, config, radius_models);
  // With the search's own error, doubled: the searches scatter 1.1-2.9 times their stated
  // error (seed-92 design bags, thesis lab and catwalk). Counted as exact, one search on part
  // of the cameras that read a 5" NC50 joint 7-14 mm over withheld its pose (classifyEnd) until
  // the next decision, ten and more cycles later (thesis_vertical, seed 1).
  constexpr double kSearchScatter = 2.0;
  if (rs.ok) measured->add(rs.radius, kSearchScatter * rs.std);
}

/// Once an end's searched radii are sure of its current joint OD (at least twice
/// typing.min_measurements of them), searches come only every kSettled-th decision: each
/// refits the end two to five times, and the cluttered scene's tracks restart often. Until then
/// every decision searches: a pin end lying on the catwalk needs about ten (seed 92).
constexpr int kSettled = 5;

/// Whether an end of type `type` with searched radii `measured` searches at this decision
/// (kSettled; *count counts its decisions once it is sure).
bool searchDue(const RadiusMean& measured, int type, const std::vector<PipeCandidate>& cands,
               const TypingConfig& tc, int* count) {
  const size_t enough = static_cast<size_t>(std::max(1, tc.min_measurements));
  const bool sure =
      measured.count() >= 2 * enough &&
      jointOdProbability(radiusProbabilities({&measured}, cands, tc), cands, type) >=
          tc.switch_probability;
  return !sure || ++*count % kSettled == 0;
}

/// The type an end fitted with type `current` takes on its searched radii's probabilities `pm`:
/// their top type where it has another joint OD and is `switch_probability` likely, or the
/// current joint OD has fallen below 1 - that; else `current`.
int searchedType(const std::vector<double>& pm, const std::vector<PipeCandidate>& cands,
                 int current, double switch_probability) {
  const int top = topType(pm);
  if (top < 0 || sameJointOd(cands[top], cands[current])) return current;
  if (pm[top] >= switch_probability ||
      jointOdProbability(pm, cands, current) < 1.0 - switch_probability)
    return top;
  return current;
}

/// The type end `slot` takes at a decision. The joint's radius is searched for at the
/// decision (measureJointRadius: the end refitted with models of other radii until one explains
/// the points) and averaged on the track; measured against its own model alone, a joint of
/// another size reads only part of the way to its radius. Another joint OD takes over when its
/// type is typing.switch_probability likely on that mean, or the current OD has become
/// unlikely. Among the types that share the current joint OD, the tube's evidence decides in
/// the same way.
int nextType(int slot, const Candidate& cd, const std::vector<PipeCandidate>& cands,
             const std::vector<double>& p, const RadiusMean* partner, EndType* et_out,
             const EstimatorConfig& config, RadiusModelCache* radius_models) {
  EndType& et = *et_out;
  const double sp = config.typing.switch_probability;
  const size_t enough = static_cast<size_t>(std::max(1, config.typing.min_measurements));
  if (cands.size() > 1 && searchDue(et.measured, et.type, cands, config.typing, &et.decisions))
    searchJointRadius(slot, cd, et.type, config, radius_models, &et.measured);
  if (et.measured.count() >= enough) {
    const int searched =
        searchedType(searchedProbabilities(et.measured, partner, cands, config.typing), cands,
                     et.type, sp);
    if (searched != et.type) return searched;
  }
  const int top = topType(p);
  if (top >= 0 && top != et.type && et.evidence.joint.count() >= enough &&
      sameJointOd(cands[top], cands[et.type]) &&
      (p[top] >= sp || p[et.type] < 1.0 - sp))
    return top;
  return et.type;
}

/// Searched radii an end needs before they can withhold its pose (classifyEnd): one (on the
/// seed-92 design bags two left a 6-5/8" FH box end 220 mm off on average, one 90 mm, and
/// kept every other type's share right or better).
constexpr size_t kMinSearched = 1;

/// An end's searched probabilities (searchedProbabilities), or none before its first search
/// (kMinSearched).
std::optional<std::vector<double>> searchedOnce(const RadiusMean& own_radii,
                                                const RadiusMean* partner,
                                                const std::vector<PipeCandidate>& cands,
                                                const TypingConfig& tc) {
  if (own_radii.count() < kMinSearched) return std::nullopt;
  return searchedProbabilities(own_radii, partner, cands, tc);
}

/// What an end publishes of its type: each joint OD's probability as its searched radii give it
/// (`pm`; none before its first search: every OD alike), split among that OD's types as its
/// evidence's probabilities `p` do.
std::vector<double> publishedProbabilities(const std::optional<std::vector<double>>& pm,
                                           const std::vector<double>& p,
                                           const std::vector<PipeCandidate>& cands) {
  return splitByJointOd(
      pm ? *pm : std::vector<double>(cands.size(), 1.0 / static_cast<double>(cands.size())), p,
      cands);
}

/// Whether an end's searched radii (`pm`, none before its first search) make the joint OD of its
/// type `type` unlikely (below 1 - typing.switch_probability): it is fitted with the wrong
/// model, so its pose is not published until it has the type they say.
bool searchedRadiiRuleOut(const std::optional<std::vector<double>>& pm, int type,
                          const std::vector<PipeCandidate>& cands, const TypingConfig& tc) {
  return tc.enabled && pm && jointOdProbability(*pm, cands, type) < 1.0 - tc.switch_probability;
}

/// Stage "pipe type" for end `slot` with its candidate `cd` (null: none this cycle): the
/// tool-joint radius measured with the pose eliminated (radiusOffset, absolute: the model's
/// radius plus the offset) joins the end's evidence on its track, whose probabilities the end
/// publishes. At a decision (not a tracked cycle) the end may take another type (nextType);
/// its filter and its evidence then restart (another model's origin, measurements against the
/// new model). The evidence restarts when the end has had no pose for tracking.max_gap, or its
/// fit moved to another end, and with it the end's instance id: the id of the other end's
/// track (`labels`' others) where one follows it, else a new one from *next_id.
void classifyEnd(int slot, const Candidate* cd, const EndModels& models,
                 const std::vector<PipeCandidate>& cands, int64_t stamp_ns,
                 const EstimatorConfig& config, RadiusModelCache* radius_models,
                 const std::array<LabelState, kNumEnds>& labels, const RadiusMean* partner,
                 EndType* et, EndPoseFilter* filter, uint32_t* next_id, EndEstimate* e) {
  if (!e->valid) {
    if (et->last_valid_ns > 0 &&
        static_cast<double>(stamp_ns - et->last_valid_ns) * 1e-9 > config.tracking.max_gap) {
      et->evidence.reset();
      et->measured = SearchedRadii();
      et->id = 0;
      et->handed_off = false;
    }
    return;
  }
  et->last_valid_ns = stamp_ns;
  // The label's fit moved to another end (several pipes in view, its track lost): another
  // instance, with an id and evidence of its own.
  if (cd && (et->id != 0 || et->handed_off) &&
      (cd->fit.origin - et->last_origin).norm() > config.instances.track_gate) {
    if (et->id != 0) {
      et->released_id = et->id;
      et->released_origin = et->last_origin;
      et->released_ns = stamp_ns;
    }
    et->id = 0;
    et->evidence.reset();
    et->measured = SearchedRadii();
  }
  et->handed_off = false;
  if (cd) et->last_origin = cd->fit.origin;
  // An end that another track follows (an OtherEnd) keeps that track's id as the primary end.
  if (et->id == 0 && cd)
    for (const LabelState& ls : labels)
      for (const OtherEnd& o : ls.others)
        if (et->id == 0 && o.track.model == static_cast<EndLabel>(slot) &&
            (o.track.origin - cd->fit.origin).norm() <= config.instances.track_gate)
          et->id = o.id;
  if (et->id == 0) et->id = (*next_id)++;
  e->instance_id = et->id;
  if (config.typing.enabled && cd) {
    // [m] the tube counts where its points span at least this along the axis, below the taper
    // (a pin cone passes through the tube's radius): the floor's edge round a joint standing
    // in it spans at most 0.026 m (thesis_vertical), the tube in a lying joint's boxes 0.1 m on
    // average (catwalk_horizontal; seeds 93, 200, four sizes each).
    constexpr double kMinTubeExtent = 0.05;
    const auto measure = [&](double radius, RadiusMean* mean, double z_max, double min_extent) {
      const RadiusCheck rc = radiusOffset(models.models[slot], radius, cd->fit.origin, cd->fit.z,
                                          cd->pts, cd->eyes, cd->fit.inlier_mask, z_max);
      if (rc.ok && rc.extent >= min_extent) mean->add(radius + rc.offset, rc.std);
    };
    measure(models.joint_radius[slot], &et->evidence.joint,
            std::numeric_limits<double>::infinity(), 0.0);
    measure(models.tube_radius[slot], &et->evidence.tube, models.models[slot].zMin(),
            kMinTubeExtent);
  }
  std::vector<double> p = et->evidence.probabilities(cands, config.typing, et->type);
  if (config.typing.enabled && cd && !cd->tracked && et->evidence.joint.count() > 0) {
    const int next = nextType(slot, *cd, cands, p, partner, et, config, radius_models);
    if (next != et->type) {
      et->type = next;
      filter->reset();
      et->evidence.reset();
      p = et->evidence.probabilities(cands, config.typing, et->type);
    }
  }
  e->type = cands[et->type].name;
  e->type_names.clear();
  for (const PipeCandidate& c : cands) e->type_names.push_back(c.name);
  // Published: the joint OD as the searched radii say, the type within it as the evidence
  // says. Measured against its own model, a joint of another size reads only part of the way to
  // its radius, so the evidence leans toward the model: a 4-1/2" NC50 joint on the catwalk,
  // fitted with the 5" NC50 model, read 165.6 mm for 161.9 and gave its true type 0.28 on
  // average (seed 93). Before its first search (a track whose end changed goes on to its next
  // decision with its evidence restarted) every joint OD is as likely: the evidence alone gave
  // the true type under 0.01 while the published one was another (catwalk, 4" NC46, seed 93).
  const auto pm = searchedOnce(et->measured, partner, cands, config.typing);
  e->type_probabilities = publishedProbabilities(pm, p, cands);
  e->measured_od = 2 * et->evidence.joint.mean();
  e->measured_od_spread = 2 * et->evidence.joint.spread();
  e->type_measurements = et->evidence.joint.count();
  e->measured_tube_od = 2 * et->evidence.tube.mean();
  e->tube_measurements = et->evidence.tube.count();
  e->searched_od = 2 * et->measured.mean();
  e->searches_counted = et->measured.count();
  e->searches = et->measured.added();
  e->last_search_od = 2 * et->measured.last();
  // A joint whose searched radii say it is not its model's size is fitted with the wrong model:
  // its pose is biased, or lies on another joint (a 6-5/8" FH box end 8-1/4" OD, fitted with
  // the 5" NC50 model, on the pin end 1.5 m away: thesis_vertical, seed 92). Not published
  // until the end has the type its radius says.
  if (searchedRadiiRuleOut(pm, et->type, cands, config.typing)) {
    std::ostringstream s;
    s.precision(4);
    s << "pipe type being measured: the joint's radius searches read " << 2e3 * et->measured.mean()
      << " mm OD (" << et->measured.count() << " of them), unlikely for the model it is fitted with ("
      << cands[et->type].name << ", " << 1e3 * cands[et->type].dims.tool_joint_od << " mm)";
    e->valid = false;
    e->reason = s.str();
  }
}

/// End `slot` has never had a pose, and its own label's fit at this decision was rejected for
/// its residual: classifyEnd never measures such an end, yet a model of another size is what
/// fits so (a 6-5/8" FH 8-1/4" OD joint fitted with the 5" NC50 model, 41 mm too thin, was
/// rejected in every cycle, both ends: thesis_vertical, seed 200). Its joint radius is searched
/// for all the same, and the end takes another joint OD by nextType's rule (searchedType: that
/// OD's type typing.switch_probability likely, or the current one below 1 - that); the other
/// end, measured neither, takes the same type (shareConnectionType). Only while neither end has
/// a measurement: a 3-1/2" NC38 box end that took its size this way while its pin end was
/// still fitted with the 5" NC50 model, whose pin is about as thick as that joint, had its box
/// detections fit the pin model, published as the pin end 1.5 m from it for 6 cycles
/// (thesis_vertical, seed 200).
void measureRejectedEnd(int slot, const Candidate& cd, const std::vector<PipeCandidate>& cands,
                        const EstimatorConfig& config, RadiusModelCache* radius_models,
                        const EndType& other, EndType* et, EndPoseFilter* filter) {
  const bool other_measured = other.evidence.joint.count() > 0 || other.measured.count() > 0;
  if (!config.typing.enabled || cands.size() < 2 || et->last_valid_ns != 0 || other_measured ||
      cd.ok || !cd.poor_fit || !cd.fit.ok || cd.tracked || static_cast<int>(cd.fit.label) != slot)
    return;
  searchJointRadius(slot, cd, et->type, config, radius_models, &et->measured);
  if (et->measured.count() < kMinSearched) return;
  const int next =
      searchedType(searchedProbabilities(et->measured, &other.measured, cands, config.typing),
                   cands, et->type, config.typing.switch_probability);
  if (next == et->type) return;
  et->type = next;
  filter->reset();
  et->evidence.reset();
}

/// A new other fit of label l at `origin` (no track of it followed its cluster) that lies on an
/// end already known keeps that end's id. (Two identical pipes side by side: the primary end
/// moves between them, and without these rules their ends took a new id in a fifth of the
/// consecutive cycle pairs; found on catwalk_twin seed 120, held out on 93, 121 and 122.) Within
/// instances.track_gate of, in this order:
///  1. an other end's track that no fit follows this cycle (its own fit failed, or a decision
///     fitted its cluster): the fit continues it;
///  2. the primary end's last pose while the primary has none this cycle: the id goes with the
///     end (the primary takes it back from the other end's track when it returns there);
///  3. the end the primary left within tracking.max_gap (its fit moved to another end).
void continueKnownEnd(int l, const Eigen::Vector3d& origin, int64_t stamp_ns,
                      const EstimatorConfig& config, std::vector<bool>* followed,
                      EstimatorState* state, OtherFit* f) {
  const double gate = config.instances.track_gate;
  const std::vector<OtherEnd>& others = state->labels[l].others;
  for (size_t s = 0; s < others.size(); ++s) {
    const Track& tr = others[s].track;
    if ((*followed)[s] || tr.model != static_cast<EndLabel>(l) ||
        (tr.predict(stamp_ns, config.tracking.max_prediction) - origin).norm() > gate)
      continue;
    (*followed)[s] = true;
    f->other = static_cast<int>(s);
    return;
  }
  EndType& et = state->types[l];
  if (et.id != 0 && et.last_valid_ns != stamp_ns && (et.last_origin - origin).norm() <= gate) {
    f->id = et.id;
    et.id = 0;
    et.handed_off = true;
    return;
  }
  if (et.released_id != 0 && (et.released_origin - origin).norm() <= gate &&
      static_cast<double>(stamp_ns - et.released_ns) * 1e-9 <= config.tracking.max_gap) {
    f->id = et.released_id;
    et.released_id = 0;
  }
}

/// Other end `o` of label l, fitted (cd) with its type's model: its joint radius searched for at
/// every fit until it has typing.min_measurements searched radii, then at its track's decisions
/// as a primary end's is (searchDue), and its type switched as the searched radii say
/// (searchedType); its evidence then restarts, and its next fit takes the new type's model.
/// (Fitted with its label's model, a 4" NC46 single in the mousehole beside a 5" NC50 stump was
/// published as 5" NC50 in every cycle: drill_floor, seeds 192-194. A search at every fit
/// doubled the scene's median cycle time, 7.6 to 15.1 ms: the single's radii, 6.4 mm from the
/// 4-1/2" NC46's, are seldom sure.)
void typeOther(int l, const Candidate& cd, const std::vector<PipeCandidate>& cands,
               const EstimatorConfig& config, RadiusModelCache* radius_models,
               const RadiusMean* partner, OtherEnd* o) {
  if (!config.typing.enabled || cands.size() < 2) return;
  const size_t enough = static_cast<size_t>(std::max(1, config.typing.min_measurements));
  if (o->measured.count() < enough ||
      (!cd.tracked && searchDue(o->measured, o->type, cands, config.typing, &o->decisions)))
    searchJointRadius(l, cd, o->type, config, radius_models, &o->measured);
  if (o->measured.count() < enough) return;
  const int next =
      searchedType(searchedProbabilities(o->measured, partner, cands, config.typing), cands,
                   o->type, config.typing.switch_probability);
  if (next == o->type) return;
  o->type = next;
  o->evidence.reset();
}

/// The searched radii of the end of the other label on the axis line of label l's end `track`
/// (coaxialEnds): the nearest of the other label's primary end and its other ends with a fit
/// within tracking.max_gap (this cycle's too); null when none is. (On its own radii, the lying
/// pin end of catwalk_twin's pipe that was not the primary pair gave its true type 0.20-0.39
/// on average, seeds 192-199 and 202-205; with its box end's, 0.43-0.74.)
const RadiusMean* coaxialPartner(int l, const Track& track, const EstimatorState& state,
                                 int64_t stamp_ns, const EstimatorConfig& config) {
  // [m] and [deg]: two 5" NC50 pipes 0.4 m apart on the catwalk are not paired unless an axis
  // is 2.9 deg off over their 5 m (catwalk_twin); a joint's own radius is 60-105 mm.
  constexpr double kReach = 0.15, kMaxAngleDeg = 10.0;
  const int o = 1 - l;
  const RadiusMean* best = nullptr;
  double nearest = std::numeric_limits<double>::infinity();
  const auto consider = [&](const Track& tr, const RadiusMean& radii) {
    if (!tr.fitWithin(stamp_ns, config.tracking.max_gap) ||
        !coaxialEnds(track.origin, track.z, tr.origin, tr.z, kReach, kMaxAngleDeg))
      return;
    const double d = (tr.origin - track.origin).norm();
    if (d < nearest) nearest = d, best = &radii;
  };
  consider(state.labels[o].track, state.types[o].measured);
  for (const OtherEnd& e : state.labels[o].others) consider(e.track, e.measured);
  return best;
}

/// The searched radii that primary end `slot` counts while its own are unsure
/// (searchedProbabilities): the end's on its axis line (coaxialPartner), else the other primary
/// end's. (The primary pair of two pipes side by side may be one pipe's box end and the other's
/// pin end: which pipe is primary is not in the data. On catwalk_twin seeds 192-199 and 202-205
/// the published types and probabilities were the same either way.)
const RadiusMean* pairedRadii(int slot, const EstimatorState& state, int64_t stamp_ns,
                              const EstimatorConfig& config) {
  const RadiusMean* coaxial =
      coaxialPartner(slot, state.labels[slot].track, state, stamp_ns, config);
  return coaxial ? coaxial : &state.types[1 - slot].measured;
}

/// Other end `o` of label l, fitted (cd) with its type's models (`type_models`): its joint
/// measured against them, its type examined (typeOther), and, unless withheld, its estimate
/// added to result->others with its id, type and probabilities.
void publishOther(int l, const Candidate& cd, const std::vector<const EndModels*>& type_models,
                  const std::vector<PipeCandidate>& cands, RadiusModelCache* radius_models,
                  const std::vector<CycleCamera>& cams, const EstimatorConfig& config,
                  const RadiusMean* partner, OtherEnd* o, CycleResult* result) {
  // The models its fit used (its type's: set when it was created).
  const EndModels& models = *type_models[static_cast<size_t>(o->type)];
  if (config.typing.enabled) {
    const RadiusCheck rc = radiusOffset(models.models[l], models.joint_radius[l], cd.fit.origin,
                                        cd.fit.z, cd.pts, cd.eyes, cd.fit.inlier_mask);
    if (rc.ok) o->evidence.joint.add(models.joint_radius[l] + rc.offset, rc.std);
  }
  // Not published with a model its searched radii make unlikely (as a primary end is not,
  // classifyEnd), nor in the cycle it takes another type (fitted with the last one): a 4"
  // NC46 single beside a 5" NC50 stump was published as 5" NC50 in its first 5 cycles
  // (drill_floor, seeds 192-199).
  const int fitted_type = o->type;
  typeOther(l, cd, cands, config, radius_models, partner, o);
  if (o->type != fitted_type) return;
  const auto pm = searchedOnce(o->measured, partner, cands, config.typing);
  if (searchedRadiiRuleOut(pm, o->type, cands, config.typing)) return;
  EndEstimate e;
  fillEnd(l, cd, cams, config, &e, nullptr).addTo(&e, config);
  e.instance_id = o->id;
  e.type = cands[static_cast<size_t>(o->type)].name;
  for (const PipeCandidate& c : cands) e.type_names.push_back(c.name);
  e.type_probabilities =
      publishedProbabilities(pm, o->evidence.probabilities(cands, config.typing, o->type), cands);
  e.measured_od = 2 * o->evidence.joint.mean();
  e.measured_od_spread = 2 * o->evidence.joint.spread();
  e.type_measurements = o->evidence.joint.count();
  e.searched_od = 2 * o->measured.mean();
  e.searches_counted = o->measured.count();
  e.searches = o->measured.added();
  e.last_search_od = 2 * o->measured.last();
  result->others.push_back(std::move(e));
}

/// Stage "other ends" (several pipes at once): each label's other fits (fitLabel) published in
/// result->others with their own instance ids and their own type: a new end takes its label's
/// type of this cycle's fits (`fit_types`), then its own (typeOther), whose models its fits use
/// (`type_models`, CycleContext). A fit within instances.track_gate of an end
/// already published this cycle is the same end, and is dropped; a new fit on an end known
/// otherwise keeps that end's id (continueKnownEnd). A track without a fit for
/// tracking.max_gap is forgotten (its id is never reused).
void outputOthers(std::array<std::vector<OtherFit>, kNumEnds>* fits, EstimatorState* state,
                  const std::vector<const EndModels*>& type_models,
                  const std::array<int, kNumEnds>& fit_types,
                  const std::vector<PipeCandidate>& cands, RadiusModelCache* radius_models,
                  const std::vector<CycleCamera>& cams, int64_t stamp_ns,
                  const EstimatorConfig& config, CycleResult* result) {
  const double gate = config.instances.track_gate;
  const auto duplicate = [&](const Eigen::Vector3d& o) {
    for (const EndEstimate& e : result->ends)
      if (e.valid && (e.T_world_end.translation() - o).norm() < gate) return true;
    for (const EndEstimate& e : result->others)
      if ((e.T_world_end.translation() - o).norm() < gate) return true;
    return false;
  };
  // One end fitted by both labels (a pin end that some cameras box as a box end): the label with
  // more of its points is the end's, and an end the other label tracks stays its own while its
  // track goes on; the other fit is dropped. (Before, the box end's other fit was published there
  // too, as its own end: catwalk_twin seed 93, 3 reports on the pin ends; held-out seeds 192 and
  // 196, 1 and 2 within 0.2 m of a pin end whose own pose was held that cycle.)
  const auto otherLabelsEnd = [&](int l, const Candidate& cd) {
    const int o = 1 - l;
    for (const OtherFit& f : (*fits)[o])
      if (f.cd.ok && static_cast<int>(f.cd.fit.label) == o &&
          (f.cd.fit.origin - cd.fit.origin).norm() < gate && f.cd.pts.size() > cd.pts.size())
        return true;
    const auto tracked_here = [&](const Track& tr) {
      return static_cast<int>(tr.model) == o && tr.continues(stamp_ns, config.tracking.max_gap) &&
             (tr.predict(stamp_ns, config.tracking.max_prediction) - cd.fit.origin).norm() < gate;
    };
    if (tracked_here(state->labels[o].track)) return true;
    for (const OtherEnd& e : state->labels[o].others)
      if (tracked_here(e.track)) return true;
    return false;
  };
  for (int l = 0; l < kNumEnds; ++l) {
    LabelState& ls = state->labels[l];
    // Other ends that a valid fit of this cycle follows: the others may still be met by a new
    // fit. (A failed fit follows nothing: a decision's fit of the same end then started a second
    // track beside the first, and the two took turns, the end's id alternating in a tenth of
    // the cycle pairs: catwalk_twin seed 190.)
    std::vector<bool> followed(ls.others.size(), false);
    for (const OtherFit& f : (*fits)[l])
      if (f.other >= 0 && f.cd.ok && static_cast<int>(f.cd.fit.label) == l)
        followed[static_cast<size_t>(f.other)] = true;
    for (OtherFit& f : (*fits)[l]) {
      const Candidate& cd = f.cd;
      // A fit that lies farther than instances.track_gate from the end's predicted origin is of
      // another end (its own cluster missed this cycle): it never takes this end's id.
      if (f.other >= 0) {
        const Track& tr = ls.others[static_cast<size_t>(f.other)].track;
        if (cd.ok && (cd.fit.origin - tr.predict(stamp_ns, config.tracking.max_prediction)).norm() >
                         gate)
          f.other = -1;
      }
      const bool ok = cd.ok && static_cast<int>(cd.fit.label) == l &&
                      !duplicate(cd.fit.origin) && !otherLabelsEnd(l, cd);
      if (!ok) continue;
      if (f.other < 0 && f.id == 0)
        continueKnownEnd(l, cd.fit.origin, stamp_ns, config, &followed, state, &f);
      if (f.other < 0) {
        if (ls.others.size() >= static_cast<size_t>(config.instances.max_other_ends)) continue;
        ls.others.push_back(OtherEnd());
        followed.push_back(true);
        // An end that was the primary's keeps its id and is published at once; a new one
        // after instances.confirm_fits fits.
        if (f.id != 0) ls.others.back().fits = config.instances.confirm_fits - 1;
        ls.others.back().id = f.id != 0 ? f.id : state->next_id++;
        ls.others.back().type = fit_types[l];
        f.other = static_cast<int>(ls.others.size()) - 1;
      }
      OtherEnd& o = ls.others[static_cast<size_t>(f.other)];
      o.track.follow(stamp_ns,
                     {cd.fit.label, cd.fit.origin, cd.fit.z, cd.tracked, cd.direction_margin,
                      cd.has_support, cd.support_z},
                     config.tracking.max_gap, config.tracking.max_offset);
      if (o.fits < config.instances.confirm_fits) ++o.fits;
      if (o.fits < config.instances.confirm_fits) continue;
      publishOther(l, cd, type_models, cands, radius_models, cams, config,
                   coaxialPartner(l, o.track, *state, stamp_ns, config), &o, result);
    }
    // An end without a fit this cycle keeps its track (and id) for tracking.max_gap: one cycle
    // of a dropped-out joint does not make it another end.
    ls.others.erase(std::remove_if(ls.others.begin(), ls.others.end(),
                                   [&](const OtherEnd& o) {
                                     return o.track.gap(stamp_ns) > config.tracking.max_gap;
                                   }),
                    ls.others.end());
  }
}

/// Label l's other fit `k` becomes its candidate; the candidate becomes an other end (keeping
/// the primary's instance id when it was the primary's end; dropped when it had no fit).
void promoteOther(int l, size_t k, std::array<Candidate, kNumEnds>* cand,
                  std::array<std::vector<OtherFit>, kNumEnds>* others,
                  const std::array<EndType, kNumEnds>& types, const EstimatorConfig& config) {
  Candidate& cd = (*cand)[l];
  const bool own = cd.ok && static_cast<int>(cd.fit.label) == l;
  // The candidate keeps the primary's id only if it is the primary's end (a decision may
  // have chosen another end: the promoted one is then the primary's, and keeps its id).
  const bool was_primary = own && types[l].id != 0 &&
                           (cd.fit.origin - types[l].last_origin).norm() <=
                               config.instances.track_gate;
  OtherFit& f = (*others)[l][k];
  std::swap(cd, f.cd);
  f.other = -1;
  f.id = was_primary ? types[l].id : 0;
  // It starts a track of its own: a fit tracked on the label's track carries that track's
  // direction margin, which the new track must take (Track::follow keeps a decision's only).
  f.cd.tracked = false;
  if (!f.cd.ok) (*others)[l].erase((*others)[l].begin() + static_cast<std::ptrdiff_t>(k));
}

/// A connection being made: the pin end hangs over the box end, their axes opposed. Generous
/// bounds around the stabbing and drill_floor scenes' stand over its stump (lateral 0.03 m,
/// axial 0.36 m, 0 deg): within 0.3 m of the box axis, from 0.2 m into the box to 1.5 m above
/// its face, axes within 30 deg of opposed.
bool isConnection(const PinInBoxRelation& r) {
  return r.lateral_offset < 0.3 && r.axial_standoff > -0.2 && r.axial_standoff < 1.5 &&
         r.axis_angle < 30.0 * M_PI / 180.0;
}

/// Stage "primary pair" (several pipes at once): which of each label's ends this cycle - its
/// candidate and its other ends' valid fits - is published as box_end/pose and pin_end/pose.
/// With instances.handling_point, each label's end nearest that point. Otherwise, with
/// instances.primary_by_standoff, the box end and pin end of the connection being made
/// (isConnection) with the smallest stand-off (the distance between their origins); without
/// such a pair, the candidates (the best-fitting ends) stay. Another end takes a candidate's
/// place only when nearer by more than instances.track_gate (two fits that close are one end),
/// so the choice holds from cycle to cycle.
void choosePrimaryPair(std::array<Candidate, kNumEnds>* cand,
                       std::array<std::vector<OtherFit>, kNumEnds>* others,
                       const std::array<EndType, kNumEnds>& types, const EstimatorConfig& config) {
  const double gate = config.instances.track_gate;
  const auto fitOf = [&](int l, int k) -> const Candidate* {  // k = -1: the candidate
    const Candidate& c = k < 0 ? (*cand)[l] : (*others)[l][static_cast<size_t>(k)].cd;
    return c.ok && static_cast<int>(c.fit.label) == l ? &c : nullptr;
  };
  const std::vector<double>& hp = config.instances.handling_point;
  if (hp.size() == 3) {
    const Eigen::Vector3d point(hp[0], hp[1], hp[2]);
    for (int l = 0; l < kNumEnds; ++l) {
      const Candidate* own = fitOf(l, -1);
      int best = -1;
      double best_d = own ? (own->fit.origin - point).norm() - gate
                          : std::numeric_limits<double>::infinity();
      for (size_t k = 0; k < (*others)[l].size(); ++k)
        if (const Candidate* o = fitOf(l, static_cast<int>(k)))
          if ((o->fit.origin - point).norm() < best_d)
            best_d = (o->fit.origin - point).norm(), best = static_cast<int>(k);
      if (best >= 0) promoteOther(l, static_cast<size_t>(best), cand, others, types, config);
    }
    return;
  }
  if (!config.instances.primary_by_standoff) return;
  const auto standoff = [&](int kb, int kp) {  // infinity: not a connection being made
    const Candidate* b = fitOf(0, kb);
    const Candidate* p = fitOf(1, kp);
    if (!b || !p || !isConnection(pinInBox(b->fit.origin, b->fit.z, p->fit.origin, p->fit.z)))
      return std::numeric_limits<double>::infinity();
    return (p->fit.origin - b->fit.origin).norm();
  };
  const double current = standoff(-1, -1);
  int best_b = -1, best_p = -1;
  double best = current - gate;
  for (int kb = -1; kb < static_cast<int>((*others)[0].size()); ++kb)
    for (int kp = -1; kp < static_cast<int>((*others)[1].size()); ++kp)
      if (standoff(kb, kp) < best) best = standoff(kb, kp), best_b = kb, best_p = kp;
  if (best_b >= 0) promoteOther(0, static_cast<size_t>(best_b), cand, others, types, config);
  if (best_p >= 0) promoteOther(1, static_cast<size_t>(best_p), cand, others, types, config);
}

/// A box end and a pin end are made up only within one connection type: an end without a
/// measurement of its own takes the other end's type once that end has changed type on its
/// evidence (a 3-1/2" NC38 box end is rejected by the 5" NC50 model in most cycles, and would
/// never measure its way to its size: thesis_vertical, seed 92).
void shareConnectionType(std::array<EndType, kNumEnds>* types,
                         std::array<EndPoseFilter, kNumEnds>* filters, const TypingConfig& tc) {
  if (!tc.enabled) return;
  for (int slot = 0; slot < kNumEnds; ++slot) {
    EndType& et = (*types)[slot];
    const EndType& other = (*types)[1 - slot];
    if (et.evidence.joint.count() > 0 || et.measured.count() > 0 || other.type == et.type ||
        (other.evidence.joint.count() == 0 && other.measured.count() == 0))
      continue;
    et.type = other.type;
    (*filters)[slot].reset();
  }
}

/// Stage "one joint, one end": a valid end and the other end's pose (this cycle's, or else
/// its last valid one within tracking.max_gap: the node may still hold it) on one joint facing
/// one way (endsOnOneJoint) cannot both be right: one label's model has fitted the other's joint.
/// The end that left its own last valid pose (farther than instances.track_gate, or none within
/// tracking.max_gap) is withheld, both ends when both or neither did; a withheld end's filter
/// restarts. Then each valid end's pose is remembered. (A 3-1/2" NC38 box joint, fitted with the
/// pin model by the box detections, was published as the pin end, 1.5 m from it, and held there
/// for 6 cycles: thesis_vertical, seed 200, 4-3/4" OD joints, typing.wear 0.)
void withholdEndsOnOneJoint(int64_t stamp_ns, const EstimatorConfig& config,
                            EstimatorState* state, std::array<EndEstimate, kNumEnds>* ends) {
  // [m] off the other's axis line (fits scatter by millimetres), [m] apart along it (a joint's
  // tongs are 0.2-0.4 m long: config/pipe_catalog.yaml), [deg] parallel within (as coaxialEnds'
  // antiparallel).
  constexpr double kReach = 0.05, kAlong = 0.5, kMaxAngleDeg = 10.0;
  const double max_gap = config.tracking.max_gap, gate = config.instances.track_gate;
  const auto recent = [&](int slot) {
    const double gap = static_cast<double>(stamp_ns - state->last_pose_ns[slot]) * 1e-9;
    return state->last_pose_ns[slot] > 0 && gap >= 0 && gap <= max_gap;
  };
  std::array<bool, kNumEnds> clash{}, left{};
  for (int slot = 0; slot < kNumEnds; ++slot) {
    const EndEstimate& e = (*ends)[slot];
    const EndEstimate& other = (*ends)[1 - slot];
    if (!e.valid || !(other.valid || recent(1 - slot))) continue;
    const Eigen::Isometry3d& o = other.valid ? other.T_world_end : state->last_pose[1 - slot];
    const Eigen::Vector3d p = e.T_world_end.translation();
    clash[slot] = endsOnOneJoint(p, e.T_world_end.linear().col(2), o.translation(),
                                 o.linear().col(2), kReach, kAlong, kMaxAngleDeg);
    left[slot] = !recent(slot) || (state->last_pose[slot].translation() - p).norm() > gate;
  }
  const bool both = left[0] == left[1];
  for (int slot = 0; slot < kNumEnds; ++slot) {
    EndEstimate& e = (*ends)[slot];
    if (e.valid && (clash[0] || clash[1]) && (both || left[slot])) {
      e.valid = false;
      e.reason = std::string("lies on the ") + labelName(static_cast<EndLabel>(1 - slot)) +
                 "'s joint, facing the same way: one joint cannot be both ends (one model "
                 "fitted the other's joint)";
      state->filters[slot].reset();
    }
    if (e.valid) {
      state->last_pose[slot] = e.T_world_end;
      state->last_pose_ns[slot] = stamp_ns;
    }
  }
}

}  // namespace

PoseEstimator::PoseEstimator(const EstimatorConfig& config) : config_(config) {
  validateConfig(config_);
  impl_ = std::make_unique<Impl>(config_);
  if (config_.method == EstimatorMethod::kThesisBaseline)
    impl_->state.baseline = std::make_unique<ThesisBaseline>(config_);
  for (auto& f : impl_->state.filters) f = EndPoseFilter(config_.temporal);
  impl_->state.drift = DriftWatch(config_.drift);
}

PoseEstimator::~PoseEstimator() = default;

void PoseEstimator::reset() {
  EstimatorState& s = impl_->state;
  if (s.baseline) s.baseline->reset();
  for (auto& f : s.filters) f.reset();
  for (auto& l : s.labels) l = LabelState();
  for (auto& t : s.types) {  // ids go on: never reused
    t = EndType();
    t.type = impl_->start;
  }
  s.drift.reset();
  s.last_pose_ns = {{0, 0}};
}

CycleResult PoseEstimator::process(const std::vector<CameraInput>& inputs) {
  const auto t_start = Clock::now();
  EstimatorState& state = impl_->state;
  CycleResult result;
  for (int l = 0; l < kNumEnds; ++l) {
    result.ends[l].label = static_cast<EndLabel>(l);
    result.ends[l].valid = false;
  }
  std::vector<CycleCamera> cams = assembleCameras(inputs, config_.cutout.min_confidence, &result);
  if (cams.empty()) {
    for (auto& e : result.ends)
      e.reason = inputs.empty() ? "no camera input in this cycle" : "no valid camera input";
    result.timing.total_ms = msSince(t_start);
    return result;
  }
  int64_t stamp_ns = 0;  // the cycle's latest capture stamp (docs/conventions.md)
  for (const CameraInput& in : inputs) stamp_ns = std::max(stamp_ns, in.frame.stamp_ns);
  if (state.baseline) {
    state.baseline->process(cams, &result);
    result.timing.total_ms = msSince(t_start);
    return result;
  }

  // Frames that carry their amplitude had their weak-return bias corrected at the cut-out
  // (cutOutCamera): the final fit's predicted correction (profile_fit.reflectivity, for frames
  // without one) must not apply it again. In a cycle where any camera carries amplitude, that
  // fallback is off for all of them.
  const bool measured =
      config_.noise.amplitude_model &&
      std::any_of(cams.begin(), cams.end(),
                  [](const CycleCamera& c) { return !c.amplitude.empty(); });
  const EstimatorConfig& config =
      measured && config_.profile_fit.reflectivity > 0 ? impl_->withoutPredictedBias(config_)
                                                       : config_;
  // Each pixel's weak-return bias out of its depth, once for every stage that reads it.
  for (CycleCamera& cam : cams) correctWeakReturns(&cam, config);
  const std::vector<CycleCamera> left_out = takeLeftOut(&cams, state.drift, config.drift);

  // Cut-out.
  auto t0 = Clock::now();
  std::array<std::vector<CloudPoint>, kNumEnds> raw;
  for (size_t c = 0; c < cams.size(); ++c)
    cutOutCamera(cams[c], static_cast<uint16_t>(c), config, &raw);
  result.timing.cutout_ms = msSince(t0);

  // Carving (fusion).
  t0 = Clock::now();
  std::array<std::vector<CloudPoint>, kNumEnds> carved;
  for (int l = 0; l < kNumEnds; ++l)
    carved[l] = carve(raw[l], static_cast<EndLabel>(l), cams, config.carving);
  for (int l = 0; l < kNumEnds; ++l)
    for (const auto& p : carved[l]) result.fused.push_back(p.p_world);
  result.timing.fusion_ms = msSince(t0);

  // Instances, axis fit, hypotheses, refinement: per label (in parallel with threads >= 2;
  // the labels share nothing they write).
  const EndModels& models = impl_->models(config);
  // The models of the types this cycle's fits use: the labels' and each other end's own (built
  // here, before the labels are fitted in parallel, which only look them up).
  const std::array<int, kNumEnds> fit_types{{state.types[0].type, state.types[1].type}};
  std::vector<const EndModels*> type_models(impl_->candidates.size(), nullptr);
  const auto need = [&](int t) {
    if (t >= 0 && !type_models[static_cast<size_t>(t)])
      type_models[static_cast<size_t>(t)] = &impl_->modelsOf(config, t, t);
  };
  for (int l = 0; l < kNumEnds; ++l) {
    need(fit_types[l]);
    for (const OtherEnd& o : state.labels[l].others) need(o.type);
  }
  const CycleContext ctx{config, models, cams, stamp_ns,
                         boxDecides(cams, state.labels[0].track, stamp_ns, config.tracking),
                         &type_models};
  std::array<Candidate, kNumEnds> cand;
  std::array<LabelTiming, kNumEnds> timing;
  std::array<std::vector<OtherFit>, kNumEnds> other_fits;
  auto fitOne = [&](int l) {
    cand[l] = fitLabel(ctx, l, raw[l], carved[l], &state.labels[l], &timing[l],
                       &result.instances[l], &other_fits[l]);
  };
  if (config.threads >= 2) {
    auto other = std::async(std::launch::async, fitOne, 1);
    fitOne(0);
    other.get();
  } else {
    for (int l = 0; l < kNumEnds; ++l) fitOne(l);
  }
  result.timing.segmentation_ms = timing[0].segmentation_ms + timing[1].segmentation_ms;
  result.timing.registration_ms = timing[0].registration_ms + timing[1].registration_ms;
  result.timing.edges_ms = timing[0].edges_ms + timing[1].edges_ms;

  choosePrimaryPair(&cand, &other_fits, state.types, config);
  const std::array<bool, kNumEnds> held = holdLabelFlips(&cand, &state.labels, stamp_ns, config);
  updateTracks(cand, held, &state.labels, stamp_ns, config.tracking);
  const std::array<int, kNumEnds> owner = assignEnds(cand, config.instances.track_gate);
  for (int slot = 0; slot < kNumEnds; ++slot) {
    const Candidate* cd = owner[slot] < 0 ? nullptr : &cand[owner[slot]];
    if (!cd)
      measureRejectedEnd(slot, cand[slot], impl_->candidates, config, &impl_->radius_models,
                         state.types[1 - slot], &state.types[slot], &state.filters[slot]);
    outputEnd(slot, cd, cand, cams, stamp_ns, &state.filters[slot], config, &result);
    classifyEnd(slot, cd, models, impl_->candidates, stamp_ns, config,
                &impl_->radius_models, state.labels, pairedRadii(slot, state, stamp_ns, config),
                &state.types[slot],
                &state.filters[slot],
                &state.next_id, &result.ends[slot]);
  }
  withholdEndsOnOneJoint(stamp_ns, config, &state, &result.ends);
  shareConnectionType(&state.types, &state.filters, config.typing);
  outputOthers(&other_fits, &state, type_models, fit_types, impl_->candidates,
               &impl_->radius_models, cams, stamp_ns, config, &result);
  if (config.drift.enabled)
    watchDrift(cams, left_out, raw, cand, owner, models, stamp_ns, config, &state.drift,
               &result);
  result.timing.total_ms = msSince(t_start);
  return result;
}

}  // namespace drill_pipe_pose
