#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <set>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/stages.hpp"
#include "drill_pipe_pose/core/estimator/temporal_filter.hpp"
#include "drill_pipe_pose/core/estimator/thesis_baseline.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"

namespace drill_pipe_pose {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// One label's fitted candidate.
struct Candidate {
  bool ok = false;
  EndLabel detected = EndLabel::kBoxEnd;  ///< label of the detections the points came from
  ProfileFitResult fit;                   ///< fit of the model that won (fit.label)
  std::string reason;
  std::vector<Eigen::Vector3f> pts;
  std::vector<uint16_t> cams;
  std::vector<Eigen::Vector3f> eyes;  ///< world position of the camera of each point
  double direction_margin = 0.0;  ///< score of the flipped axis direction minus the winner's
  /// The position along the axis comes from the scan (locked in the refinement): the fit's
  /// covariance does not describe it.
  bool axial_from_scan = false;
  /// With axial_from_scan: the rise of the scan's score 1 cm either side of its best position
  /// (the smaller one), in score units (EstimatorConfig::FreeSpace).
  double axial_contrast = 0.0;
  /// The model and direction came from the end's track (no hypothesis decision this cycle).
  bool tracked = false;
  /// The level support found at the decision (or the track's): the points below
  /// support_z + profile_fit.support_clearance are left out of the pose refinement.
  bool has_support = false;
  float support_z = 0.0f;  ///< [m] world height of the support
  /// The points the pose refinement used (of pts): the fit's inliers are counted among them.
  size_t fit_points = 0;
};

/// The last valid fit of the points of one detected label (EstimatorConfig::Tracking).
struct Track {
  bool valid = false;
  EndLabel model = EndLabel::kBoxEnd;  ///< the model that fitted
  Eigen::Vector3d origin = Eigen::Vector3d::Zero(), z = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< [m/s] from the last two poses
  int64_t stamp_ns = 0;
  int cycles = 0;  ///< cycles since the last full decision (1 = this track's decision cycle)
  double direction_margin = 0.0;
  bool has_support = false;  ///< the support of the last decision (Candidate)
  float support_z = 0.0f;
};

}  // namespace

struct PoseEstimator::Impl {
  std::array<ProfileModel, kNumEnds> models;
  std::array<ProfileModel, kNumEnds> search_models;  ///< tong 0.3 m longer (wear-proof search)
  /// Camera-facing surface samples (end frame) for the free-space check: the tool joint with
  /// free_space.tube_length of tube.
  std::array<std::vector<OrientedPoint>, kNumEnds> fs_samples;
  std::unique_ptr<ThesisBaseline> baseline;
  std::array<EndPoseFilter, kNumEnds> filters;
  std::array<Track, kNumEnds> tracks;  ///< per detected label
  std::array<std::vector<InstanceMemory>, kNumEnds> memory;  ///< per detected label
  /// Per detected label: consecutive decisions whose fit took the other model against the
  /// label's last fit of its own (a label correction waits for instances.min_decisions of them).
  std::array<int, kNumEnds> flips{{0, 0}};
};

PoseEstimator::PoseEstimator(const EstimatorConfig& config)
    : config_(config), impl_(std::make_unique<Impl>()) {
  validateConfig(config_);
  impl_->models[0] = ProfileModel(EndLabel::kBoxEnd, config_.dims);
  impl_->models[1] = ProfileModel(EndLabel::kPinEnd, config_.dims);
  ToolJointDimensions long_tong = config_.dims;
  long_tong.box_tong_length += 0.3;
  long_tong.pin_tong_length += 0.3;
  impl_->search_models[0] = ProfileModel(EndLabel::kBoxEnd, long_tong);
  impl_->search_models[1] = ProfileModel(EndLabel::kPinEnd, long_tong);
  for (int l = 0; l < kNumEnds; ++l) {
    const ProfileModel& m = impl_->models[l];
    // The joint with its taper and tube_length of tube: a flipped or mislabelled model predicts
    // surface there that the cameras see through (a worn taper is off by less than a pixel).
    const double z_lo = m.zMin() - config_.free_space.tube_length;
    ToolJointDimensions d = config_.dims;
    d.tube_length = config_.free_space.tube_length;
    for (const OrientedPoint& s :
         sampleProfileSurface(toolJointProfile(static_cast<EndLabel>(l), d),
                              config_.free_space.sample_spacing, 1, true)) {
      if (s.p.z() < z_lo + 1e-3 || s.p.z() > m.zMax() + 1e-6) continue;
      impl_->fs_samples[l].push_back(s);
    }
  }
  if (config_.method == EstimatorMethod::kThesisBaseline)
    impl_->baseline = std::make_unique<ThesisBaseline>(config_);
  for (auto& f : impl_->filters) f = EndPoseFilter(config_.temporal);
}

PoseEstimator::~PoseEstimator() = default;

void PoseEstimator::reset() {
  if (impl_->baseline) impl_->baseline->reset();
  for (auto& f : impl_->filters) f.reset();
  for (auto& t : impl_->tracks) t = Track();
  for (auto& m : impl_->memory) m.clear();
  impl_->flips = {{0, 0}};
}

/// 6x6 world covariance (x y z, rotation about world x y z) from a 5-DoF profile fit.
static Eigen::Matrix<double, 6, 6> worldCovariance(const ProfileFitResult& fit,
                                                   const EstimatorConfig::Covariance& c) {
  const Eigen::Vector3d e1 = fit.basis.col(0), e2 = fit.basis.col(1), z = fit.basis.col(2);
  // Params: a1 a2 a3 (origin along e1 e2 z), b1 b2 (z tilts toward e1, e2: rotation z x e).
  Eigen::Matrix<double, 6, 5> M = Eigen::Matrix<double, 6, 5>::Zero();
  M.block<3, 1>(0, 0) = e1;
  M.block<3, 1>(0, 1) = e2;
  M.block<3, 1>(0, 2) = z;
  M.block<3, 1>(3, 3) = z.cross(e1);
  M.block<3, 1>(3, 4) = z.cross(e2);
  Eigen::Matrix<double, 6, 6> C = c.inflation * M * fit.covariance * M.transpose();
  Eigen::Matrix3d R;
  R << e1, e2, z;
  const Eigen::Vector3d pos_floor(c.min_lateral_std * c.min_lateral_std,
                                  c.min_lateral_std * c.min_lateral_std,
                                  c.min_axial_std * c.min_axial_std);
  const Eigen::Vector3d rot_floor(c.min_tilt_std * c.min_tilt_std, c.min_tilt_std * c.min_tilt_std,
                                  c.roll_variance);
  C.block<3, 3>(0, 0) += R * pos_floor.asDiagonal() * R.transpose();
  C.block<3, 3>(3, 3) += R * rot_floor.asDiagonal() * R.transpose();
  return 0.5 * (C + C.transpose());
}

/// The rig calibration's share of an end's covariance (EstimatorConfig::Covariance::extrinsic_*)
/// for an end on axis `z` fitted to the points of `n` cameras at a mean `range` [m], its inliers
/// spanning `length` [m] along the axis: each camera's extrinsic error moves its points by
/// t^2 + (rotation range)^2 in each direction and tilts the axis by rotation^2 + (t / length)^2
/// (two cameras' points offset against each other across the joint's length); n cameras average
/// them. A bias for a fixed rig: it is added after the temporal filter, which cannot reduce it.
static Eigen::Matrix<double, 6, 6> calibrationCovariance(const Eigen::Vector3d& z, size_t n,
                                                        double range, double length,
                                                        const EstimatorConfig::Covariance& c) {
  const double t2 = c.extrinsic_translation_std * c.extrinsic_translation_std;
  const double r2 = c.extrinsic_rotation_std * c.extrinsic_rotation_std;
  const double pos = (t2 + r2 * range * range) / static_cast<double>(n);
  const double tilt = (r2 + t2 / std::pow(std::max(length, 0.1), 2)) / static_cast<double>(n);
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();
  C.topLeftCorner<3, 3>() = pos * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d u = z.normalized();
  C.bottomRightCorner<3, 3>() = tilt * (Eigen::Matrix3d::Identity() - u * u.transpose());
  return C;
}

/// Reported std [m] of a fit's position along its axis.
static double axialStd(const ProfileFitResult& fit, const EstimatorConfig::Covariance& c) {
  const Eigen::Matrix<double, 6, 6> C = worldCovariance(fit, c);
  const Eigen::Vector3d z = fit.z.normalized();
  return std::sqrt(std::max(0.0, z.dot(C.topLeftCorner<3, 3>() * z)));
}

CycleResult PoseEstimator::process(const std::vector<CameraInput>& inputs) {
  const auto t_start = Clock::now();
  CycleResult result;
  for (int l = 0; l < kNumEnds; ++l) {
    result.ends[l].label = static_cast<EndLabel>(l);
    result.ends[l].valid = false;
  }
  // Validate cameras; a bad one is skipped and named.
  std::vector<CycleCamera> cams;
  cams.reserve(inputs.size());
  for (const CameraInput& in : inputs) {
    try {
      cams.push_back(makeCycleCamera(in.frame, in.T_world_depth, in.T_color_depth,
                                     config_.cutout.min_confidence));
      result.cameras_used.push_back(in.frame.camera);
    } catch (const InputError& e) {
      result.camera_errors.push_back(e.what());
    }
  }
  if (cams.empty()) {
    for (auto& e : result.ends)
      e.reason = inputs.empty() ? "no camera input in this cycle" : "no valid camera input";
    result.timing.total_ms = msSince(t_start);
    return result;
  }
  int64_t cycle_stamp_ns = 0;  // the cycle's latest capture stamp (DESIGN.md)
  for (const CameraInput& in : inputs) cycle_stamp_ns = std::max(cycle_stamp_ns, in.frame.stamp_ns);
  if (impl_->baseline) {
    impl_->baseline->process(cams, &result);
    result.timing.total_ms = msSince(t_start);
    return result;
  }

  // 1. Cut-out.
  auto t0 = Clock::now();
  std::array<std::vector<CloudPoint>, kNumEnds> raw;
  for (size_t c = 0; c < cams.size(); ++c)
    cutOutCamera(cams[c], static_cast<uint16_t>(c), config_, &raw);
  result.timing.cutout_ms = msSince(t0);

  // 2. Fusion: visual-hull carving per label.
  t0 = Clock::now();
  std::array<std::vector<CloudPoint>, kNumEnds> carved;
  for (int l = 0; l < kNumEnds; ++l)
    carved[l] = carve(raw[l], static_cast<EndLabel>(l), cams, config_.carving);
  for (int l = 0; l < kNumEnds; ++l)
    for (const auto& p : carved[l]) result.fused.push_back(p.p_world);
  result.timing.fusion_ms = msSince(t0);

  // 3. Segmentation: robust cylinder axis; 4. registration against both models.
  std::array<Candidate, kNumEnds> cand;
  // A full decision is planned for the box end's label in this cycle (it has no track to follow,
  // or its periodic one is due): the pin end's periodic one waits a cycle (the two ends'
  // decisions fall in different cycles, halving the slowest cycles' time).
  bool first_decides = false;
  for (const auto& cam : cams) first_decides = first_decides || cam.has_label[0];
  if (first_decides) {
    const Track& tr = impl_->tracks[0];
    const double gap_s = static_cast<double>(cycle_stamp_ns - tr.stamp_ns) * 1e-9;
    first_decides = !(tr.valid && gap_s > 0 && gap_s <= config_.tracking.max_gap &&
                      tr.cycles < config_.tracking.redecide_every);
  }
  std::array<double, kNumEnds> seg_ms{}, reg_ms{};
  // One instance's candidate (the points of one cluster of label l's carved points): its
  // tracked fit when `follow_track`, else (or when the track is lost) its decided fit.
  auto fitInstance = [&](int l, const std::vector<CloudPoint>& points, bool follow_track,
                         Candidate& cd) {
    const bool decided_this_cycle = l == 1 && first_decides;
    auto t0 = Clock::now();
    cd.detected = static_cast<EndLabel>(l);
    // Deterministic subsample to max_points.
    const size_t stride =
        std::max<size_t>(1, (points.size() + config_.profile_fit.max_points - 1) /
                                config_.profile_fit.max_points);
    std::vector<float> sig;
    for (size_t i = 0; i < points.size(); i += stride) {
      cd.pts.push_back(points[i].p_world);
      sig.push_back(points[i].sigma);
      cd.cams.push_back(points[i].camera);
      cd.eyes.push_back(cams[points[i].camera].T_world_depth.translation().cast<float>());
    }
    cd.fit_points = cd.pts.size();
    const auto& fsc = config_.free_space;
    const auto& trc = config_.tracking;
    const double T2 = config_.profile_fit.truncation * config_.profile_fit.truncation;
    // Symmetric score of a pose, in "unexplained measurement" units: every point costs its
    // truncated squared distance / truncation^2 (an unexplained point costs 1), every depth pixel
    // on which the model claims a surface that the camera saw through costs pixel_weight. The
    // same points and cameras judge every hypothesis (2 models x 2 axis directions), so nothing
    // is gained by hiding a model below a floor or outside the views.
    const bool use_fs = fsc.enabled && fsc.decide_hypotheses;
    auto poseScore = [&](int m, const std::vector<Eigen::Vector3f>& P,
                         const std::vector<Eigen::Vector3f>* E, double n_scale,
                         const Eigen::Vector3d& o, const Eigen::Vector3d& z) {
      double c = profileCost(P, impl_->models[m], o, z, config_.profile_fit.truncation, E) / T2 *
                 n_scale;
      if (use_fs)
        c += fsc.pixel_weight * static_cast<double>(seenThroughPixels(
                                    impl_->fs_samples[m], canonicalPose(o, z), cams, fsc.margin,
                                    config_.noise, fsc.min_cos_incidence));
      return c;
    };
    // Scan of the position along the axis (origin + delta z) minimising poseScore: a coarse pass
    // over +-range at `step`, then +-step at step / 2 (or finer when `fine` > 0). With
    // `coarse_points_only` the coarse pass ranks positions by the points' cost alone and the
    // seen-through pixels are counted in the fine pass only (a quarter of the projections);
    // with `points_only` they are not counted at all.
    auto axialScan = [&](int m, const std::vector<Eigen::Vector3f>& P,
                         const std::vector<Eigen::Vector3f>* E, double n_scale,
                         ProfileFitResult* f, double range, double step, double fine,
                         bool coarse_points_only, bool points_only = false) {
      auto pointsScore = [&](const Eigen::Vector3d& o) {
        return profileCost(P, impl_->models[m], o, f->z, config_.profile_fit.truncation, E);
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
    };
    // The coarse subsample (every stride-th point) of the end's points.
    const size_t n_coarse = config_.profile_fit.coarse_points;
    const size_t coarse_stride = std::max<size_t>(1, (cd.pts.size() + n_coarse - 1) / n_coarse);
    std::vector<Eigen::Vector3f> coarse_pts, coarse_eyes;
    std::vector<float> coarse_sig;
    for (size_t i = 0; i < cd.pts.size(); i += coarse_stride) {
      coarse_pts.push_back(cd.pts[i]);
      coarse_eyes.push_back(cd.eyes[i]);
      coarse_sig.push_back(sig[i]);
    }
    // The winner's fine position along the axis with the points of the trusted (unworn) part
    // (the points alone: at this scale the seen-through pixels add noise, not information),
    // then the 5-DoF refinement with projective (camera-ray) correspondences, which are unbiased
    // by the depth noise at the joint's edges (closest-point matching pulls the end face outward).
    auto refineWinner = [&](int win) {
      const ProfileModel& model = impl_->models[win];
      // Near a level support (floor, catwalk) the floor and the joint's foot cannot be told
      // apart (their points join within the depth noise, and the floor's pull tilts the axis):
      // the refinement leaves out the points less than support_clearance above it (all are used
      // when fewer than axis_fit.min_points would be left). The decisions and the fit's cost
      // judge every point.
      // (has_support is only set with support_clearance > 0.)
      const float z_clear =
          cd.support_z + static_cast<float>(config_.profile_fit.support_clearance);
      auto clear = [&](const Eigen::Vector3f& p) { return p.z() >= z_clear; };
      std::vector<size_t> fit_idx;
      if (cd.has_support)
        for (size_t i = 0; i < cd.pts.size(); ++i)
          if (clear(cd.pts[i])) fit_idx.push_back(i);
      const bool subset = cd.has_support && fit_idx.size() < cd.pts.size() &&
                          fit_idx.size() >= config_.axis_fit.min_points;
      std::vector<Eigen::Vector3f> fit_pts, fit_eyes, fc_pts, fc_eyes;
      std::vector<float> fit_sig, fc_sig;
      if (subset) {
        for (size_t i : fit_idx) {
          fit_pts.push_back(cd.pts[i]);
          fit_eyes.push_back(cd.eyes[i]);
          fit_sig.push_back(sig[i]);
        }
        for (size_t i = 0; i < coarse_pts.size(); ++i)
          if (clear(coarse_pts[i])) {
            fc_pts.push_back(coarse_pts[i]);
            fc_eyes.push_back(coarse_eyes[i]);
            fc_sig.push_back(coarse_sig[i]);
          }
      }
      const auto& r_pts = subset ? fit_pts : cd.pts;
      const auto& r_eyes = subset ? fit_eyes : cd.eyes;
      const auto& r_sig = subset ? fit_sig : sig;
      const auto& rc_pts = subset ? fc_pts : coarse_pts;
      const auto& rc_eyes = subset ? fc_eyes : coarse_eyes;
      const auto& rc_sig = subset ? fc_sig : coarse_sig;
      const double z_trust = model.trustedMinZ(config_.profile_fit.wear_margin);
      std::vector<Eigen::Vector3f> trusted, trusted_eyes;
      for (size_t i = 0; i < rc_pts.size(); ++i)
        if ((rc_pts[i].cast<double>() - cd.fit.origin).dot(cd.fit.z) > z_trust + 0.03) {
          trusted.push_back(rc_pts[i]);
          trusted_eyes.push_back(rc_eyes[i]);
        }
      ProfileFitResult f0 = cd.fit;
      axialScan(win, trusted, &trusted_eyes, static_cast<double>(trusted.size()) * coarse_stride,
                &f0, fsc.decision_step, fsc.axial_step, fsc.axial_step / 2, true, true);
      // Refined with the position along the axis free and locked: the one with the lower
      // truncated cost wins (the free one follows the end face's points, but can slide along a
      // joint whose shoulder and nose the cameras barely see, leaving them as outliers). Both
      // converge on the coarse subsample; the winner is then polished on every point.
      auto converge = [&](bool lock) {
        return refineProfile(rc_pts, rc_sig, f0.origin, f0.z, model, config_.profile_fit,
                             config_.profile_fit.iterations, lock, &rc_eyes);
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
      // When no point carries information along the axis (all of them on the tong's cylinder:
      // a reported axial std of metres), the position along it is the scan's, and the fit's
      // covariance does not describe it. Weak information is left to the gate below. (The
      // coarse fit's std, scaled to every point.)
      const double coarse_to_all =
          std::sqrt(static_cast<double>(rc_pts.size()) / std::max<size_t>(1, r_pts.size()));
      cd.axial_from_scan = f.ok && axialStd(f, config_.covariance) * coarse_to_all > 1.0;
      const bool lock = fl.ok && (!f.ok || fl.cost < f.cost || cd.axial_from_scan);
      if (lock) f = fl;
      // Only the better one is polished on every point.
      if (f.ok && coarse_stride > 1)
        f = refineProfile(r_pts, r_sig, f.origin, f.z, model, config_.profile_fit,
                          config_.profile_fit.polish_iterations, lock, &r_eyes);
      if (cd.axial_from_scan) {
        // How sharply the scan's score pins the position: the smaller rise at +-1 cm.
        const double n_sc = static_cast<double>(trusted.size()) * coarse_stride;
        const double c0 = poseScore(win, trusted, &trusted_eyes, n_sc, f0.origin, f0.z);
        const double step = 0.01;
        cd.axial_contrast =
            std::min(poseScore(win, trusted, &trusted_eyes, n_sc, f0.origin - step * f0.z, f0.z),
                     poseScore(win, trusted, &trusted_eyes, n_sc, f0.origin + step * f0.z, f0.z)) -
            c0;
      }
      if (f.ok) {
        cd.fit = f;
        cd.fit_points = r_pts.size();
        if (subset) {
          // The inliers as a mask over every point; the cost over every point (the instances
          // and the labels compete by it).
          cd.fit.inlier_mask.assign(cd.pts.size(), 0);
          for (size_t j = 0; j < fit_idx.size(); ++j)
            cd.fit.inlier_mask[fit_idx[j]] = f.inlier_mask[j];
          cd.fit.cost = profileCost(cd.pts, model, f.origin, f.z, config_.profile_fit.truncation,
                                    &cd.eyes);
        }
      }
      return f.ok;
    };

    // Points of the decision scans (deterministic subsample), scaled to the full count.
    std::vector<Eigen::Vector3f> scan_pts;
    {
      const size_t st = std::max<size_t>(1, cd.pts.size() / config_.profile_fit.search_points);
      for (size_t i = 0; i < cd.pts.size(); i += st) scan_pts.push_back(cd.pts[i]);
    }
    const double n_scale = static_cast<double>(cd.pts.size());

    // Tracking: the last cycle's pose of this label, moved on by its velocity, gives the model,
    // the axis direction and the start of the refinement; the track holds while the refined pose
    // stays within tracking.max_angle / max_offset of that prediction.
    Track& tr = impl_->tracks[l];
    const double gap_s = static_cast<double>(cycle_stamp_ns - tr.stamp_ns) * 1e-9;
    const int due = trc.redecide_every + (decided_this_cycle ? 1 : 0);
    const bool trackable = follow_track && trc.enabled && fsc.enabled && fsc.axial_scan &&
                           tr.valid && gap_s > 0 && gap_s <= trc.max_gap;
    cd.tracked = trackable && tr.cycles < due;
    // A periodic decision of a continuing track re-decides the model and the direction on the
    // track's axis (no support-plane removal and axis fit).
    const bool periodic = trackable && !cd.tracked;
    // The track's origin moved on by its velocity (at most max_prediction).
    Eigen::Vector3d move = tr.velocity * gap_s;
    if (move.norm() > trc.max_prediction) move *= trc.max_prediction / move.norm();
    const Eigen::Vector3d pred = tr.origin + move;
    if (trackable) {
      cd.has_support = tr.has_support;
      cd.support_z = tr.support_z;
    }
    if (cd.tracked) {
      t0 = Clock::now();
      cd.fit = ProfileFitResult();
      cd.fit.ok = true;
      cd.fit.label = tr.model;
      cd.fit.origin = pred;
      cd.fit.z = tr.z;
      cd.direction_margin = tr.direction_margin;
      // The position along the axis as in the decision (free-space evidence over +-axial_range):
      // starting the fine scan from the last pose alone lets the axial position random-walk.
      axialScan(static_cast<int>(tr.model), scan_pts, nullptr, n_scale, &cd.fit, fsc.axial_range,
                fsc.decision_step, 0.0, true);
      const bool refined = refineWinner(static_cast<int>(tr.model));
      const Eigen::Vector3d q = cd.fit.origin - pred;
      cd.tracked = refined &&
                   std::acos(std::clamp(cd.fit.z.dot(tr.z), -1.0, 1.0)) <= trc.max_angle &&
                   (q - q.dot(tr.z) * tr.z).norm() <= trc.max_offset &&
                   std::abs(q.dot(tr.z)) <= trc.max_offset;
      reg_ms[l] += msSince(t0);
    }
    if (!cd.tracked) {
      // A floor or catwalk around the joint is not part of it: left out of the axis fit (the
      // profile registration and the decision judge every point, with the same cost for all).
      t0 = Clock::now();
      AxisFitResult axis;
      if (periodic) {
        axis.ok = true;
        axis.axis.point = pred;
        axis.axis.direction = tr.z;
      } else {
        std::vector<Eigen::Vector3f> axis_pts;
        for (size_t k : removeSupportPlane(cd.pts, config_.axis_fit))
          axis_pts.push_back(cd.pts[k]);
        if (axis_pts.size() < config_.axis_fit.min_points) {
          seg_ms[l] += msSince(t0);
          cd.reason =
              std::to_string(axis_pts.size()) + " points left after removing the support plane";
          return;
        }
        axis = fitCylinderAxis(axis_pts, config_.dims.tool_joint_od / 2, config_.axis_fit);
        cd.has_support = axis.ok && config_.profile_fit.support_clearance > 0 &&
                         findLevelSupport(cd.pts, axis.axis, config_.dims.tool_joint_od / 2,
                                          config_.axis_fit, &cd.support_z);
      }
      seg_ms[l] += msSince(t0);
      if (!axis.ok) {
        cd.reason =
            "cylinder-axis fit found no tool joint in " + std::to_string(cd.pts.size()) + " points";
        return;
      }
      t0 = Clock::now();
      // Both models x both axis directions, each at its best position along the axis.
      std::array<ProfileFitResult, kNumEnds> fits;
      std::array<double, kNumEnds> cost{};
      std::array<double, kNumEnds> flip_cost{};
      auto hypothesesOf = [&](int m) {
        // Refined on the coarse subsample: they only need to be close enough for the decision.
        auto hyp = fitProfileHypotheses(
            coarse_pts, coarse_sig, axis.axis, impl_->models[m], config_.profile_fit,
            config_.profile_fit.long_tong_search ? &impl_->search_models[m] : nullptr);
        std::array<double, 2> c{
            {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()}};
        for (int k = 0; k < 2; ++k)
          if (hyp[k].ok)
            c[k] = fsc.enabled && fsc.axial_scan
                       ? axialScan(m, scan_pts, nullptr, n_scale, &hyp[k], fsc.axial_range,
                                   fsc.decision_step, 0.0, true)
                       : poseScore(m, scan_pts, nullptr, n_scale, hyp[k].origin, hyp[k].z);
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
      const int other = 1 - l;
      int win = l;
      if (cost[other] < (1.0 - config_.profile_fit.label_margin) * cost[l]) win = other;
      cd.fit = fits[win];
      cd.direction_margin = flip_cost[win] - cost[win];
      const bool refined = cd.fit.ok && fsc.enabled && fsc.axial_scan && refineWinner(win);
      if (cd.fit.ok && !refined) {
        // The hypothesis's fit, on the coarse subsample: its inliers as a mask over every point.
        std::vector<uint8_t> mask(cd.pts.size(), 0);
        for (size_t i = 0; i < cd.fit.inlier_mask.size(); ++i)
          mask[i * coarse_stride] = cd.fit.inlier_mask[i];
        cd.fit.inlier_mask = std::move(mask);
        cd.fit_points = coarse_pts.size();
      }
      reg_ms[l] += msSince(t0);
    }
    if (!cd.fit.ok) {
      cd.reason = "model registration failed";
      return;
    }
    if (use_fs && cd.direction_margin < fsc.min_direction_margin) {
      std::ostringstream s;
      s << "axis direction ambiguous: the flipped pose scores only " << cd.direction_margin
        << " worse (< free_space.min_direction_margin = " << fsc.min_direction_margin << ")";
      cd.reason = s.str();
      return;
    }
    const double inlier_fraction = static_cast<double>(cd.fit.inliers) / cd.fit_points;
    if (cd.fit.rms > config_.profile_fit.max_rms ||
        inlier_fraction < config_.profile_fit.min_inlier_fraction) {
      std::ostringstream s;
      s << "model fit rejected: RMS residual " << cd.fit.rms * 1000 << " mm, inliers "
        << cd.fit.inliers << "/" << cd.fit_points;
      cd.reason = s.str();
      return;
    }
    if (cd.axial_from_scan && cd.axial_contrast < fsc.min_axial_contrast) {
      std::ostringstream s;
      s << "position along the axis not determined: no point constrains it, and the scan's "
           "score 1 cm away differs by only "
        << cd.axial_contrast << " (< free_space.min_axial_contrast = " << fsc.min_axial_contrast
        << ")";
      cd.reason = s.str();
      return;
    }
    {
      // A pose the points do not pin down (dark steel: the shoulder and the taper drop out) is
      // not published: its reported uncertainty says so.
      const Eigen::Matrix<double, 6, 6> C = worldCovariance(cd.fit, config_.covariance);
      const double axial_std = axialStd(cd.fit, config_.covariance);
      const Eigen::Vector3d e1 = cd.fit.basis.col(0), e2 = cd.fit.basis.col(1);
      const double tilt_std = std::sqrt(
          std::max(0.0, 0.5 * (e1.dot(C.bottomRightCorner<3, 3>() * e1) +
                               e2.dot(C.bottomRightCorner<3, 3>() * e2))));
      if ((!cd.axial_from_scan && axial_std > config_.profile_fit.max_axial_std) ||
          tilt_std > config_.profile_fit.max_tilt_std) {
        std::ostringstream s;
        s << "pose not determined by the points: reported std " << axial_std * 1000
          << " mm along the axis, " << tilt_std * 180 / M_PI << " deg tilt (limits "
          << config_.profile_fit.max_axial_std * 1000 << " mm, "
          << config_.profile_fit.max_tilt_std * 180 / M_PI << " deg)";
        cd.reason = s.str();
        return;
      }
    }
    cd.ok = true;
  };
  // One label's candidate: its carved points split into instances (clusters); a continuing track
  // follows the instance at its prediction, otherwise the largest instances are decided and the
  // best-fitting valid one is the label's candidate. The labels share nothing they write: with
  // threads >= 2 they run in parallel.
  auto fitLabel = [&](int l) {
    Candidate& cd = cand[l];
    cd.detected = static_cast<EndLabel>(l);
    bool any_box = false;
    for (const auto& cam : cams) any_box = any_box || cam.has_label[l];
    if (!any_box) {
      cd.reason = std::string("no ") + labelName(cd.detected) + " detection in any camera";
      return;
    }
    if (carved[l].size() < config_.axis_fit.min_points) {
      std::ostringstream s;
      s << raw[l].size() << " points cut out, " << carved[l].size()
        << " after carving (< axis_fit.min_points = " << config_.axis_fit.min_points << ")";
      cd.reason = s.str();
      return;
    }
    const auto t0 = Clock::now();
    std::vector<std::vector<size_t>> clusters = euclideanClusters(
        carved[l], config_.instances.cluster_tolerance, config_.axis_fit.min_points);
    {
      // An instance is measured by at least carving.min_cameras cameras (fewer when fewer have
      // a box of the label): one camera that calls the other end by this label does not make one.
      int with_label = 0;
      for (const auto& cam : cams) with_label += cam.has_label[l] ? 1 : 0;
      const size_t need = static_cast<size_t>(std::min(config_.carving.min_cameras, with_label));
      std::vector<std::vector<size_t>> kept;
      for (auto& c : clusters) {
        std::set<uint16_t> seen;
        for (size_t i : c) seen.insert(carved[l][i].camera);
        if (seen.size() >= need) kept.push_back(std::move(c));
      }
      clusters = std::move(kept);
    }
    auto pointsOf = [&](size_t k) {
      std::vector<CloudPoint> p;
      p.reserve(clusters[k].size());
      for (size_t i : clusters[k]) p.push_back(carved[l][i]);
      return p;
    };
    seg_ms[l] += msSince(t0);
    result.instances[l] = static_cast<uint32_t>(clusters.size());
    if (clusters.empty()) {
      std::ostringstream s;
      s << carved[l].size() << " points after carving, no cluster of axis_fit.min_points = "
        << config_.axis_fit.min_points << " from carving.min_cameras = "
        << config_.carving.min_cameras << " cameras (instances.cluster_tolerance = "
        << config_.instances.cluster_tolerance << " m)";
      cd.reason = s.str();
      return;
    }
    const auto& ic = config_.instances;
    // A continuing track takes the instance with a point nearest its predicted origin.
    const Track& tr = impl_->tracks[l];
    const double gap_s = static_cast<double>(cycle_stamp_ns - tr.stamp_ns) * 1e-9;
    int track_k = -1;
    if (tr.valid && gap_s > 0 && gap_s <= config_.tracking.max_gap) {
      Eigen::Vector3d move = tr.velocity * gap_s;
      if (move.norm() > config_.tracking.max_prediction)
        move *= config_.tracking.max_prediction / move.norm();
      const Eigen::Vector3f pred = (tr.origin + move).cast<float>();
      size_t best_k = 0;
      float best_d2 = std::numeric_limits<float>::infinity();
      for (size_t k = 0; k < clusters.size(); ++k)
        for (size_t i : clusters[k]) {
          const float d2 = (carved[l][i].p_world - pred).squaredNorm();
          if (d2 < best_d2) best_d2 = d2, best_k = k;
        }
      if (best_d2 <= ic.track_gate * ic.track_gate) track_k = static_cast<int>(best_k);
    }
    // The instances decided this cycle: the track's (when its fit is not simply tracked: a
    // periodic decision, or the track was lost) and the largest others.
    std::vector<Candidate> inst;
    if (track_k >= 0) {
      Candidate c;
      fitInstance(l, pointsOf(static_cast<size_t>(track_k)), true, c);
      if (c.tracked) {
        cd = std::move(c);
        return;
      }
      inst.push_back(std::move(c));
    }
    for (size_t k = 0; k < clusters.size() && inst.size() < static_cast<size_t>(ic.max_instances);
         ++k) {
      if (static_cast<int>(k) == track_k) continue;
      inst.emplace_back();
      fitInstance(l, pointsOf(k), false, inst.back());
    }
    // Instances that fit this label's model compete; the other model's (the other end, called
    // by this label in some cameras) only when none does (the label is then corrected).
    bool any_native = false;
    for (const Candidate& c : inst) any_native = any_native || (c.ok && c.fit.label == cd.detected);
    std::vector<InstanceFit> fits(inst.size());
    for (size_t k = 0; k < inst.size(); ++k) {
      const Candidate& c = inst[k];
      fits[k] = {c.ok && (!any_native || c.fit.label == cd.detected), c.fit.origin, c.fit.cost,
                 {}};
      if (fits[k].competes && ic.radius_difference > 0)
        fits[k].radius = radiusOffset(impl_->models[static_cast<int>(c.fit.label)],
                                      config_.dims.tool_joint_od / 2, c.fit.origin, c.fit.z,
                                      c.pts, c.eyes, c.fit.inlier_mask);
    }
    const InstanceChoice choice = chooseInstance(
        &impl_->memory[l], fits, track_k >= 0 ? 0 : -1, cycle_stamp_ns,
        [&](const Eigen::Vector3d& o, double radius) {
          const Eigen::Vector3f of = o.cast<float>();
          const float r2 = static_cast<float>(radius * radius);
          size_t near = 0;
          for (const auto& p : raw[l]) near += (p.p_world - of).squaredNorm() <= r2 ? 1 : 0;
          return near;
        },
        config_.axis_fit.min_points, ic, labelName(cd.detected));
    if (choice.index >= 0) {
      cd = std::move(inst[static_cast<size_t>(choice.index)]);
    } else if (!choice.reason.empty()) {
      cd = Candidate();
      cd.detected = static_cast<EndLabel>(l);
      cd.reason = choice.reason;
    } else {
      cd = std::move(inst[0]);
      if (inst.size() > 1)
        cd.reason =
            "no instance fits (" + std::to_string(inst.size()) + "); the first: " + cd.reason;
    }
  };
  if (config_.threads >= 2) {
    auto other = std::async(std::launch::async, fitLabel, 1);
    fitLabel(0);
    other.get();
  } else {
    for (int l = 0; l < kNumEnds; ++l) fitLabel(l);
  }
  result.timing.segmentation_ms = seg_ms[0] + seg_ms[1];
  result.timing.registration_ms = reg_ms[0] + reg_ms[1];
  // A decision whose fit takes the other model while the label's last valid fit (within
  // tracking.max_gap) took its own - one cycle of a dark joint whose cone drops out, say - is
  // not published until instances.min_decisions decisions in a row say so; its track, if any,
  // goes on meanwhile. A label with no recent fit of its own model is corrected at once (a
  // detector that swaps the labels in every camera).
  std::array<bool, kNumEnds> flip_held{{false, false}};
  for (int l = 0; l < kNumEnds; ++l) {
    Candidate& cd = cand[l];
    if (!cd.ok || cd.tracked) continue;
    if (static_cast<int>(cd.fit.label) == l) {
      impl_->flips[l] = 0;
      continue;
    }
    const Track& tr = impl_->tracks[l];
    const double gap_s = static_cast<double>(cycle_stamp_ns - tr.stamp_ns) * 1e-9;
    if (!(tr.stamp_ns > 0 && static_cast<int>(tr.model) == l && gap_s > 0 &&
          gap_s <= config_.tracking.max_gap))
      continue;
    if (++impl_->flips[l] >= config_.instances.min_decisions) continue;
    std::ostringstream s;
    s << "the " << labelName(cd.detected) << " detections fit the " << labelName(cd.fit.label)
      << " model in this decision, against their last fit (" << impl_->flips[l] << " of "
      << config_.instances.min_decisions << " decisions in a row needed to correct the label)";
    cd.ok = false;
    cd.reason = s.str();
    flip_held[l] = true;
  }
  // Tracks follow each label's valid fits; a label without one ends its track.
  for (int l = 0; l < kNumEnds; ++l) {
    Track& tr = impl_->tracks[l];
    const Candidate& cd = cand[l];
    if (flip_held[l]) continue;
    if (!cd.ok) {
      tr.valid = false;
      continue;
    }
    const double gap_s = static_cast<double>(cycle_stamp_ns - tr.stamp_ns) * 1e-9;
    // The velocity follows a continuing track only; a jump (a re-decided pose far from the
    // track's prediction) restarts it from zero.
    const bool continues =
        tr.valid && gap_s > 0 && gap_s <= config_.tracking.max_gap &&
        tr.model == cd.fit.label && tr.z.dot(cd.fit.z) > 0 &&
        (cd.fit.origin - (tr.origin + tr.velocity * gap_s)).norm() <= config_.tracking.max_offset;
    tr.velocity = continues ? Eigen::Vector3d((cd.fit.origin - tr.origin) / gap_s)
                            : Eigen::Vector3d::Zero();
    tr.cycles = cd.tracked ? tr.cycles + 1 : 1;
    if (!cd.tracked) tr.direction_margin = cd.direction_margin;
    tr.valid = true;
    tr.model = cd.fit.label;
    tr.origin = cd.fit.origin;
    tr.z = cd.fit.z;
    tr.stamp_ns = cycle_stamp_ns;
    tr.has_support = cd.has_support;
    tr.support_z = cd.support_z;
  }

  // Assign candidates to ends by the model that fits; the detected label wins a tie.
  std::array<int, kNumEnds> owner{{-1, -1}};
  for (int l = 0; l < kNumEnds; ++l) {
    if (!cand[l].ok) continue;
    const int slot = static_cast<int>(cand[l].fit.label);
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
  for (int slot = 0; slot < kNumEnds; ++slot) {
    EndEstimate& e = result.ends[slot];
    const int l = owner[slot];
    if (l < 0) {
      // Explain: the slot's own candidate failed, or was moved to the other end.
      const Candidate& own = cand[slot];
      if (own.ok && static_cast<int>(own.fit.label) != slot)
        e.reason = std::string("the ") + labelName(static_cast<EndLabel>(slot)) +
                   " detections fit the " + labelName(own.fit.label) + " model (label corrected)";
      else if (own.ok)
        e.reason = "duplicate of another end";
      else
        e.reason = own.reason;
      continue;
    }
    const Candidate& cd = cand[l];
    e.valid = true;
    e.reason.clear();
    e.label_corrected = l != slot;
    e.tracked = cd.tracked;
    e.T_world_end = canonicalPose(cd.fit.origin, cd.fit.z);
    e.covariance = worldCovariance(cd.fit, config_.covariance);
    e.residual = cd.fit.rms;
    e.points = cd.fit.inliers;
    std::set<uint16_t> used;
    double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo;
    for (size_t i = 0; i < cd.pts.size(); ++i)
      if (cd.fit.inlier_mask[i]) {
        used.insert(cd.cams[i]);
        result.segmented[slot].push_back(cd.pts[i]);
        const double zi = (cd.pts[i].cast<double>() - cd.fit.origin).dot(cd.fit.z);
        z_lo = std::min(z_lo, zi);
        z_hi = std::max(z_hi, zi);
      }
    double range_sum = 0;
    for (uint16_t c : used) {
      e.cameras.push_back(cams[c].name);
      range_sum += (cams[c].T_world_depth.translation() - cd.fit.origin).norm();
    }
    if (config_.temporal.enabled) {
      Eigen::Vector3d o = e.T_world_end.translation(), z = e.T_world_end.linear().col(2);
      EndPoseFilter& filter = impl_->filters[slot];
      if (filter.update(cycle_stamp_ns, &o, &z, &e.covariance) == FilterUpdate::kHeld) {
        // One fit far from the end's filtered track: a wild fit, or the pipe moved. Not
        // published until the next agrees (temporal.confirmations).
        std::ostringstream s;
        s.precision(3);
        s << "held: this cycle's pose lies " << filter.lastPositionSigma()
          << " sigma and " << filter.lastTilt() * 180 / M_PI << " deg (gate "
          << filter.lastTiltGate() * 180 / M_PI << ") from the end's filtered track "
          << "(temporal.gate_sigma = " << config_.temporal.gate_sigma
          << "); published when temporal.confirmations = " << config_.temporal.confirmations
          << " more agree";
        const EndLabel label = e.label;
        e = EndEstimate();
        e.label = label;
        e.reason = s.str();
        continue;
      }
      e.T_world_end = canonicalPose(o, z);
    }
    if (!used.empty())
      e.covariance += calibrationCovariance(e.T_world_end.linear().col(2), used.size(),
                                            range_sum / used.size(), z_hi - z_lo,
                                            config_.covariance);
  }
  result.timing.total_ms = msSince(t_start);
  return result;
}

}  // namespace drill_pipe_pose
