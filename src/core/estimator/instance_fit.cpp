#include "instance_fit.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "drill_pipe_pose/core/estimator/covariance.hpp"
#include "drill_pipe_pose/core/estimator/edge_likelihood.hpp"
#include "drill_pipe_pose/core/estimator/seen_through.hpp"
#include "drill_pipe_pose/core/estimator/support_plane.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"

namespace drill_pipe_pose {

namespace {

/// The points a refinement uses: every point of the instance, or those clear of a level support
/// (a subset). Views into the caller's vectors.
struct RefinePoints {
  bool subset = false;
  std::vector<size_t> idx;  ///< with subset: indices (into all points) of the points kept
  std::vector<Eigen::Vector3f> own_pts, own_eyes, own_coarse_pts, own_coarse_eyes;
  std::vector<float> own_sig, own_coarse_sig;
  const std::vector<Eigen::Vector3f>*pts, *eyes, *coarse_pts, *coarse_eyes;
  const std::vector<float>*sig, *coarse_sig;
};

}  // namespace

InstanceFitter::InstanceFitter(const CycleContext& ctx, int label,
                               const std::vector<CloudPoint>& points)
    : ctx_(ctx), config_(ctx.config), label_(label) {
  cd_.detected = static_cast<EndLabel>(label);
  // Deterministic subsample to max_points.
  const size_t stride =
      std::max<size_t>(1, (points.size() + config_.profile_fit.max_points - 1) /
                              config_.profile_fit.max_points);
  for (size_t i = 0; i < points.size(); i += stride) {
    cd_.pts.push_back(points[i].p_world);
    cd_.sigmas.push_back(points[i].sigma);
    cd_.cams.push_back(points[i].camera);
    cd_.eyes.push_back(ctx.cams[points[i].camera].T_world_depth.translation().cast<float>());
  }
  cd_.fit_points = cd_.pts.size();
  // The coarse subsample (every stride-th point) of the end's points.
  const size_t n_coarse = config_.profile_fit.coarse_points;
  coarse_stride_ = std::max<size_t>(1, (cd_.pts.size() + n_coarse - 1) / n_coarse);
  for (size_t i = 0; i < cd_.pts.size(); i += coarse_stride_) {
    coarse_pts_.push_back(cd_.pts[i]);
    coarse_eyes_.push_back(cd_.eyes[i]);
    coarse_sig_.push_back(cd_.sigmas[i]);
  }
  // Points of the decision scans (deterministic subsample), scaled to the full count.
  const size_t st = std::max<size_t>(1, cd_.pts.size() / config_.profile_fit.search_points);
  for (size_t i = 0; i < cd_.pts.size(); i += st) scan_pts_.push_back(cd_.pts[i]);
  n_scale_ = static_cast<double>(cd_.pts.size());
}

double InstanceFitter::poseScore(int m, const Points& P, const Points* E, double n_scale,
                                 const Eigen::Vector3d& o, const Eigen::Vector3d& z) const {
  // The same points and cameras judge every hypothesis (2 models x 2 axis directions), so
  // nothing is gained by hiding a model below a floor or outside the views.
  const auto& fsc = config_.free_space;
  const double T2 = config_.profile_fit.truncation * config_.profile_fit.truncation;
  double c = profileCost(P, ctx_.models.models[m], o, z, config_.profile_fit.truncation, E) / T2 *
             n_scale;
  if (fsc.enabled && fsc.decide_hypotheses)
    c += fsc.pixel_weight *
         static_cast<double>(seenThroughPixels(ctx_.models.fs_samples[m], canonicalPose(o, z),
                                               ctx_.cams, fsc.margin, config_.noise,
                                               fsc.min_cos_incidence));
  return c;
}

double InstanceFitter::axialScan(int m, const Points& P, const Points* E, double n_scale,
                                 ProfileFitResult* f, double range, double step, double fine,
                                 bool coarse_points_only, bool points_only) const {
  auto pointsScore = [&](const Eigen::Vector3d& o) {
    return profileCost(P, ctx_.models.models[m], o, f->z, config_.profile_fit.truncation, E);
  };
  auto coarseScore = [&](const Eigen::Vector3d& o) {
    return coarse_points_only || points_only ? pointsScore(o)
                                             : poseScore(m, P, E, n_scale, o, f->z);
  };
  auto fineScore = [&](const Eigen::Vector3d& o) {
    return points_only ? pointsScore(o) : poseScore(m, P, E, n_scale, o, f->z);
  };
  double best_d = 0, best = coarseScore(f->origin);
  for (double d = -range; d <= range + 1e-9; d += step) {
    if (std::abs(d) < 1e-9) continue;
    const double c = coarseScore(f->origin + d * f->z);
    if (c < best) best = c, best_d = d;
  }
  const double fs = fine > 0 ? fine : step / 2;
  const double d0 = best_d;
  if (coarse_points_only && !points_only) best = fineScore(f->origin + d0 * f->z);
  for (double d = d0 - step + fs; d < d0 + step - 1e-9; d += fs) {
    if (std::abs(d - d0) < 1e-9) continue;
    const double c = fineScore(f->origin + d * f->z);
    if (c < best) best = c, best_d = d;
  }
  f->origin += best_d * f->z;
  return best;
}

Candidate InstanceFitter::fit(const Track& tr, bool follow_track, LabelTiming* timing) {
  timing_ = timing;
  const auto& fsc = config_.free_space;
  const auto& trc = config_.tracking;
  // Tracking: the last cycle's pose of this label, moved on by its velocity, gives the model,
  // the axis direction and the start of the refinement; the track holds while the refined pose
  // stays within tracking.max_angle / max_offset of that prediction.
  const bool decided_this_cycle = label_ == 1 && ctx_.box_decides;
  const int due = trc.redecide_every + (decided_this_cycle ? 1 : 0);
  const bool trackable = follow_track && trc.enabled && fsc.enabled && fsc.axial_scan &&
                         tr.continues(ctx_.stamp_ns, trc.max_gap);
  cd_.tracked = trackable && tr.cycles < due;
  // A periodic decision of a continuing track re-decides the model and the direction on the
  // track's axis (no support-plane removal and axis fit).
  const bool periodic = trackable && !cd_.tracked;
  const Eigen::Vector3d pred = tr.predict(ctx_.stamp_ns, trc.max_prediction);
  if (trackable) {
    cd_.has_support = tr.has_support;
    cd_.support_z = tr.support_z;
  }
  // How far the end moves between the cycle's first and last frame: unsynchronised cameras see
  // a moving end at different places, and the edge scan reads their pixels as one pose.
  if (tr.recent(ctx_.stamp_ns, trc.max_gap) && !ctx_.cams.empty()) {
    const auto [first, last] = std::minmax_element(
        ctx_.cams.begin(), ctx_.cams.end(),
        [](const CycleCamera& a, const CycleCamera& b) { return a.stamp_ns < b.stamp_ns; });
    const double spread_s = static_cast<double>(last->stamp_ns - first->stamp_ns) * 1e-9;
    motion_ = tr.mean_velocity.norm() * spread_s;
  }
  if (cd_.tracked) followTrack(tr, pred);
  if (!cd_.tracked) {
    AxisFitResult axis;
    if (!decisionAxis(periodic, tr, pred, &axis)) return std::move(cd_);
    decideHypotheses(axis);
  }
  gate();
  return std::move(cd_);
}

void InstanceFitter::followTrack(const Track& tr, const Eigen::Vector3d& pred) {
  const auto& fsc = config_.free_space;
  const auto& trc = config_.tracking;
  const auto t0 = Clock::now();
  cd_.fit = ProfileFitResult();
  cd_.fit.ok = true;
  cd_.fit.label = tr.model;
  cd_.fit.origin = pred;
  cd_.fit.z = tr.z;
  cd_.direction_margin = tr.direction_margin;
  // The position along the axis as in the decision (free-space evidence over +-axial_range):
  // starting the fine scan from the last pose alone lets the axial position random-walk.
  axialScan(static_cast<int>(tr.model), scan_pts_, nullptr, n_scale_, &cd_.fit, fsc.axial_range,
            fsc.decision_step, 0.0, true);
  const bool refined = refineWinner(static_cast<int>(tr.model));
  const Eigen::Vector3d q = cd_.fit.origin - pred;
  cd_.tracked = refined &&
                std::acos(std::clamp(cd_.fit.z.dot(tr.z), -1.0, 1.0)) <= trc.max_angle &&
                (q - q.dot(tr.z) * tr.z).norm() <= trc.max_offset &&
                std::abs(q.dot(tr.z)) <= trc.max_offset;
  timing_->registration_ms += msSince(t0);
}

bool InstanceFitter::decisionAxis(bool periodic, const Track& tr, const Eigen::Vector3d& pred,
                                  AxisFitResult* axis) {
  // A floor or catwalk around the joint is not part of it: left out of the axis fit (the
  // profile registration and the decision judge every point, with the same cost for all).
  const auto t0 = Clock::now();
  if (periodic) {
    axis->ok = true;
    axis->axis.point = pred;
    axis->axis.direction = tr.z;
  } else {
    std::vector<Eigen::Vector3f> axis_pts;
    for (size_t k : removeSupportPlane(cd_.pts, config_.axis_fit)) axis_pts.push_back(cd_.pts[k]);
    if (axis_pts.size() < config_.axis_fit.min_points) {
      timing_->segmentation_ms += msSince(t0);
      cd_.reason =
          std::to_string(axis_pts.size()) + " points left after removing the support plane";
      return false;
    }
    // The known radius: that of the detected label's end type.
    const double radius = ctx_.models.joint_radius[label_];
    *axis = fitCylinderAxis(axis_pts, radius, config_.axis_fit);
    cd_.has_support = axis->ok && config_.profile_fit.support_clearance > 0 &&
                      findLevelSupport(cd_.pts, axis->axis, radius, config_.axis_fit,
                                       &cd_.support_z);
  }
  timing_->segmentation_ms += msSince(t0);
  if (!axis->ok) {
    cd_.reason =
        "cylinder-axis fit found no tool joint in " + std::to_string(cd_.pts.size()) + " points";
    return false;
  }
  return true;
}

void InstanceFitter::decideHypotheses(const AxisFitResult& axis) {
  const auto& fsc = config_.free_space;
  const auto t0 = Clock::now();
  // Both models x both axis directions, each at its best position along the axis.
  std::array<ProfileFitResult, kNumEnds> fits;
  std::array<double, kNumEnds> cost{};
  std::array<double, kNumEnds> flip_cost{};
  auto hypothesesOf = [&](int m) {
    // Refined on the coarse subsample: they only need to be close enough for the decision.
    auto hyp = fitProfileHypotheses(
        coarse_pts_, coarse_sig_, axis.axis, ctx_.models.models[m], config_.profile_fit,
        config_.profile_fit.long_tong_search ? &ctx_.models.search_models[m] : nullptr);
    std::array<double, 2> c{
        {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()}};
    for (int k = 0; k < 2; ++k)
      if (hyp[k].ok)
        c[k] = fsc.enabled && fsc.axial_scan
                   ? axialScan(m, scan_pts_, nullptr, n_scale_, &hyp[k], fsc.axial_range,
                               fsc.decision_step, 0.0, true)
                   : poseScore(m, scan_pts_, nullptr, n_scale_, hyp[k].origin, hyp[k].z);
    const int k = c[0] <= c[1] ? 0 : 1;
    fits[m] = hyp[k];
    cost[m] = c[k];
    flip_cost[m] = c[1 - k];
  };
  if (config_.threads >= 2) {
    auto pin = std::async(std::launch::async, hypothesesOf, 1);
    hypothesesOf(0);
    pin.get();
  } else {
    for (int m = 0; m < kNumEnds; ++m) hypothesesOf(m);
  }
  const int other = 1 - label_;
  int win = label_;
  if (cost[other] < (1.0 - config_.profile_fit.label_margin) * cost[label_]) win = other;
  cd_.fit = fits[win];
  cd_.direction_margin = flip_cost[win] - cost[win];
  const bool refined = cd_.fit.ok && fsc.enabled && fsc.axial_scan && refineWinner(win);
  if (cd_.fit.ok && !refined) {
    // The hypothesis's fit, on the coarse subsample: its inliers as a mask over every point.
    std::vector<uint8_t> mask(cd_.pts.size(), 0);
    for (size_t i = 0; i < cd_.fit.inlier_mask.size(); ++i)
      mask[i * coarse_stride_] = cd_.fit.inlier_mask[i];
    cd_.fit.inlier_mask = std::move(mask);
    cd_.fit_points = coarse_pts_.size();
  }
  timing_->registration_ms += msSince(t0);
}

bool InstanceFitter::refineWinner(int win) {
  const auto& fsc = config_.free_space;
  const ProfileModel& model = ctx_.models.models[win];
  // Near a level support (floor, catwalk) the floor and the joint's foot cannot be told apart
  // (their points join within the depth noise, and the floor's pull tilts the axis): the
  // refinement leaves out the points less than support_clearance above it (all are used when
  // fewer than axis_fit.min_points would be left). The decisions and the fit's cost judge every
  // point. (has_support is only set with support_clearance > 0.)
  RefinePoints rp;
  {
    const float z_clear =
        cd_.support_z + static_cast<float>(config_.profile_fit.support_clearance);
    auto clear = [&](const Eigen::Vector3f& p) { return p.z() >= z_clear; };
    if (cd_.has_support)
      for (size_t i = 0; i < cd_.pts.size(); ++i)
        if (clear(cd_.pts[i])) rp.idx.push_back(i);
    rp.subset = cd_.has_support && rp.idx.size() < cd_.pts.size() &&
                rp.idx.size() >= config_.axis_fit.min_points;
    if (rp.subset) {
      for (size_t i : rp.idx) {
        rp.own_pts.push_back(cd_.pts[i]);
        rp.own_eyes.push_back(cd_.eyes[i]);
        rp.own_sig.push_back(cd_.sigmas[i]);
      }
      for (size_t i = 0; i < coarse_pts_.size(); ++i)
        if (clear(coarse_pts_[i])) {
          rp.own_coarse_pts.push_back(coarse_pts_[i]);
          rp.own_coarse_eyes.push_back(coarse_eyes_[i]);
          rp.own_coarse_sig.push_back(coarse_sig_[i]);
        }
    }
    rp.pts = rp.subset ? &rp.own_pts : &cd_.pts;
    rp.eyes = rp.subset ? &rp.own_eyes : &cd_.eyes;
    rp.sig = rp.subset ? &rp.own_sig : &cd_.sigmas;
    rp.coarse_pts = rp.subset ? &rp.own_coarse_pts : &coarse_pts_;
    rp.coarse_eyes = rp.subset ? &rp.own_coarse_eyes : &coarse_eyes_;
    rp.coarse_sig = rp.subset ? &rp.own_coarse_sig : &coarse_sig_;
  }
  // The winner's fine position along the axis with the points of the trusted (unworn) part (the
  // points alone: at this scale the seen-through pixels add noise, not information).
  const double z_trust = model.trustedMinZ(config_.profile_fit.wear_margin);
  std::vector<Eigen::Vector3f> trusted, trusted_eyes;
  for (size_t i = 0; i < rp.coarse_pts->size(); ++i)
    if (((*rp.coarse_pts)[i].cast<double>() - cd_.fit.origin).dot(cd_.fit.z) > z_trust + 0.03) {
      trusted.push_back((*rp.coarse_pts)[i]);
      trusted_eyes.push_back((*rp.coarse_eyes)[i]);
    }
  ProfileFitResult f0 = cd_.fit;
  const double n_trusted = static_cast<double>(trusted.size()) * coarse_stride_;
  axialScan(win, trusted, &trusted_eyes, n_trusted, &f0, fsc.decision_step, fsc.axial_step,
            fsc.axial_step / 2, true, true);
  // The 5-DoF refinement with projective (camera-ray) correspondences, unbiased by the depth
  // noise at the joint's edges (closest-point matching pulls the end face outward). Refined with
  // the position along the axis free and locked: the one with the lower truncated cost wins (the
  // free one follows the end face's points, but can slide along a joint whose shoulder and nose
  // the cameras barely see, leaving them as outliers). Both converge on the coarse subsample;
  // the winner is then polished on every point.
  auto converge = [&](bool lock) {
    return refineProfile(*rp.coarse_pts, *rp.coarse_sig, f0.origin, f0.z, model,
                         config_.profile_fit, config_.profile_fit.iterations, lock,
                         rp.coarse_eyes);
  };
  ProfileFitResult f, fl;
  if (config_.threads >= 2) {
    auto locked = std::async(std::launch::async, converge, true);
    f = converge(false);
    fl = locked.get();
  } else {
    f = converge(false);
    fl = converge(true);
  }
  // When no point carries information along the axis (all of them on the tong's cylinder: a
  // reported axial std of metres), the position along it is the scan's, and the fit's covariance
  // does not describe it. Weak information is left to the gate. (The coarse fit's std, scaled
  // to every point.)
  const double coarse_to_all = std::sqrt(static_cast<double>(rp.coarse_pts->size()) /
                                         std::max<size_t>(1, rp.pts->size()));
  cd_.axial_from_scan = f.ok && axialStd(f, config_.covariance) * coarse_to_all > 1.0;
  const bool lock = fl.ok && (!f.ok || fl.cost < f.cost || cd_.axial_from_scan);
  if (lock) f = fl;
  // Only the better one is polished on every point.
  if (f.ok && coarse_stride_ > 1)
    f = refineProfile(*rp.pts, *rp.sig, f.origin, f.z, model, config_.profile_fit,
                      config_.profile_fit.polish_iterations, lock, rp.eyes);
  if (cd_.axial_from_scan) {
    // How sharply the scan's score pins the position: the smaller rise at +-1 cm.
    const double c0 = poseScore(win, trusted, &trusted_eyes, n_trusted, f0.origin, f0.z);
    const double step = 0.01;
    cd_.axial_contrast =
        std::min(poseScore(win, trusted, &trusted_eyes, n_trusted, f0.origin - step * f0.z, f0.z),
                 poseScore(win, trusted, &trusted_eyes, n_trusted, f0.origin + step * f0.z, f0.z)) -
        c0;
    if (f.ok) scanAxialCovariance(&f);
  }
  if (f.ok && config_.edges.enabled) {
    const auto t0 = Clock::now();
    edgeScan(win, &f);
    timing_->edges_ms += msSince(t0);
  }
  if (f.ok) {
    cd_.fit = f;
    cd_.fit_points = rp.pts->size();
    if (rp.subset) {
      // The inliers as a mask over every point; the cost over every point (the instances and
      // the labels compete by it).
      cd_.fit.inlier_mask.assign(cd_.pts.size(), 0);
      for (size_t j = 0; j < rp.idx.size(); ++j) cd_.fit.inlier_mask[rp.idx[j]] = f.inlier_mask[j];
      cd_.fit.cost = profileCost(cd_.pts, model, f.origin, f.z, config_.profile_fit.truncation,
                                 &cd_.eyes);
    }
  }
  return f.ok;
}

void InstanceFitter::edgeScan(int m, ProfileFitResult* f) const {
  const auto& ec = config_.edges;
  const ProfileModel& model = ctx_.models.models[m];
  const double margin = config_.free_space.margin;
  // Not where the end moves by more than edges.max_motion within the cycle's frames.
  if (motion_ > ec.max_motion) return;
  // One region per camera for the whole scan (every pose judged on the same pixels), and what
  // its pixels do at the refinement's pose.
  const Eigen::Isometry3d T0 = canonicalPose(f->origin, f->z);
  auto regions =
      edgeRegions(model, ctx_.models.joint_radius[m] + 0.01, T0, ctx_.cams, ec, ec.scan_range);
  EdgeOutcomes outcomes =
      estimateEdgeOutcomes(model, T0, ctx_.cams, regions, ec, config_.noise, margin);
  // A camera whose own pixels do not read as a ToF sensor's edges (its step pixels missing less
  // than edges.camera_min_step_missing, or less than 3 times its on-model ones: an occluder or a
  // dark surface in front of the end) is left out of the scan, if edges.min_cameras remain.
  int kept = 0;
  bool left_out = false;
  for (size_t c = 0; c < regions.size(); ++c) {
    if (outcomes.camera_pixels[c] == 0) continue;
    const double sm = outcomes.camera_step_missing[c], om = outcomes.camera_on_missing[c];
    if (sm >= ec.camera_min_step_missing && sm >= 3.0 * om) {
      ++kept;
    } else {
      regions[c] = EdgeRegion();
      left_out = true;
    }
  }
  if (left_out) {
    if (kept < ec.min_cameras) return;
    outcomes = estimateEdgeOutcomes(model, T0, ctx_.cams, regions, ec, config_.noise, margin);
  }
  // Only where the sensor drops its edge pixels: there the refinement's points at the end face
  // are the few it kept and mixed, and the missing ones say where the steps are.
  if (!(outcomes.step_missing >= ec.min_step_missing &&
        outcomes.step_missing >= 3.0 * outcomes.on_missing))
    return;
  // The scan needs only the pixels that its moves can change.
  keepChangingPixels(model, T0, ec.scan_range, ctx_.cams, config_.noise, margin, &regions);
  // Each offset once (the finer passes revisit the best so far): keyed in 0.1 mm.
  std::map<long, double> scored;
  auto nll = [&](double d) {
    const long key = std::lround(d * 1e4);
    const auto it = scored.find(key);
    if (it != scored.end()) return it->second;
    const double c = edgeNegLogLikelihood(model, canonicalPose(f->origin + d * f->z, f->z),
                                          ctx_.cams, regions, outcomes, config_.noise, margin);
    scored.emplace(key, c);
    return c;
  };
  // Over [lo, hi] at `step`: the best offset (the middle of the offsets that tie for the best:
  // the score is flat until a step crosses a pixel centre) and its score.
  auto scan = [&](double lo, double hi, double step, double* best) {
    double sum = 0;
    int ties = 0;
    *best = std::numeric_limits<double>::infinity();
    for (double d = lo; d <= hi + 1e-9; d += step) {
      const double c = nll(d);
      if (c < *best - 1e-9) *best = c, sum = 0, ties = 0;
      if (c <= *best + 1e-9) sum += d, ++ties;
    }
    return ties ? sum / ties : lo;
  };
  // 6 mm steps over the range (a third of a depth pixel's footprint at 6.5 m), then 3 mm steps
  // over +-3 mm and 1 mm steps over +-2 mm around the best so far.
  double best = 0, d = scan(-ec.scan_range, ec.scan_range, 0.006, &best);
  for (const auto& [step, half_width] : {std::pair{0.003, 0.003}, std::pair{0.001, 0.002}}) {
    double around = 0;
    const double da = scan(d - half_width, d + half_width, step, &around);
    if (around < best - 1e-9) best = around, d = da;
  }
  f->origin += d * f->z;
}

void InstanceFitter::scanAxialCovariance(ProfileFitResult* f) const {
  // The fit's covariance along the axis is the inverse of almost no information (centimetres to
  // 6e4 m where the information is exactly zero): replace it by the scan's own precision, reading
  // its score as a chi-square in the position: a rise c at +-1 cm is sigma = 1 cm / sqrt(c). A
  // flat or falling score (c <= 0.25, which the gate still lets through down to
  // free_space.min_axial_contrast) counts as 2 cm. The published covariance multiplies the
  // fit's by covariance.inflation, which this sigma does not need (it is read off the score, not
  // off independent per-point residuals), so it is stored divided by it. Chosen on design seeds
  // 400-402 (stabbing's hanging pin end, catwalk_horizontal's and random_poses' box ends: the
  // reported axial std was 25-45 mm, or 6e7 mm, against actual errors of 2-4 mm).
  const double sigma = 0.01 / std::sqrt(std::max(0.25, cd_.axial_contrast));
  const double inflation = std::max(1.0, config_.covariance.inflation);
  f->covariance.row(2).setZero();
  f->covariance.col(2).setZero();
  f->covariance(2, 2) = sigma * sigma / inflation;
}

void InstanceFitter::gate() {
  const auto& fsc = config_.free_space;
  const auto& pf = config_.profile_fit;
  if (!cd_.fit.ok) {
    cd_.reason = "model registration failed";
    return;
  }
  std::ostringstream s;
  if (fsc.enabled && fsc.decide_hypotheses && cd_.direction_margin < fsc.min_direction_margin) {
    s << "axis direction ambiguous: the flipped pose scores only " << cd_.direction_margin
      << " worse (< free_space.min_direction_margin = " << fsc.min_direction_margin << ")";
    cd_.reason = s.str();
    return;
  }
  const double inlier_fraction = static_cast<double>(cd_.fit.inliers) / cd_.fit_points;
  if (cd_.fit.rms > pf.max_rms || inlier_fraction < pf.min_inlier_fraction) {
    s << "model fit rejected: RMS residual " << cd_.fit.rms * 1000 << " mm, inliers "
      << cd_.fit.inliers << "/" << cd_.fit_points;
    cd_.reason = s.str();
    cd_.poor_fit = true;
    return;
  }
  if (cd_.axial_from_scan && cd_.axial_contrast < fsc.min_axial_contrast) {
    s << "position along the axis not determined: no point constrains it, and the scan's "
         "score 1 cm away differs by only "
      << cd_.axial_contrast << " (< free_space.min_axial_contrast = " << fsc.min_axial_contrast
      << ")";
    cd_.reason = s.str();
    return;
  }
  // A pose the points do not pin down (dark steel: the shoulder and the taper drop out) is not
  // published: its reported uncertainty says so.
  const Eigen::Matrix<double, 6, 6> C = worldCovariance(cd_.fit, config_.covariance);
  const double axial_std = axialStd(cd_.fit, config_.covariance);
  const Eigen::Vector3d e1 = cd_.fit.basis.col(0), e2 = cd_.fit.basis.col(1);
  const double tilt_std =
      std::sqrt(std::max(0.0, 0.5 * (e1.dot(C.bottomRightCorner<3, 3>() * e1) +
                                     e2.dot(C.bottomRightCorner<3, 3>() * e2))));
  if ((!cd_.axial_from_scan && axial_std > pf.max_axial_std) || tilt_std > pf.max_tilt_std) {
    s << "pose not determined by the points: reported std " << axial_std * 1000
      << " mm along the axis, " << tilt_std * 180 / M_PI << " deg tilt (limits "
      << pf.max_axial_std * 1000 << " mm, " << pf.max_tilt_std * 180 / M_PI << " deg)";
    cd_.reason = s.str();
    return;
  }
  cd_.ok = true;
}

}  // namespace drill_pipe_pose
