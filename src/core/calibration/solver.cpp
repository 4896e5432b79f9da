#include "drill_pipe_pose/core/calibration/solver.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <optional>
#include <set>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/metrics.hpp"

namespace drill_pipe_pose::calibration {

namespace {

using Pose6 = std::array<double, 6>;  // angle-axis (3), translation (3): T_world_x

Pose6 toPose6(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd aa(T.linear());
  const Eigen::Vector3d r = aa.axis() * aa.angle();
  const Eigen::Vector3d t = T.translation();
  return {r.x(), r.y(), r.z(), t.x(), t.y(), t.z()};
}

Eigen::Isometry3d fromPose6(const Pose6& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d r(p[0], p[1], p[2]);
  const double angle = r.norm();
  if (angle > 0) T.linear() = Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
  T.translation() = Eigen::Vector3d(p[3], p[4], p[5]);
  return T;
}

double rotationAngle(const Eigen::Matrix3d& R) {
  return std::acos(std::clamp((R.trace() - 1.0) / 2.0, -1.0, 1.0));
}

/// A half turn about the target's z axis: what reversing a chessboard's corner order does to the
/// target pose (the inner corners are symmetric about the target centre).
Eigen::Isometry3d halfTurn() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

// ---------------------------------------------------------------------------------------------
// Residuals.

/// Projection with OpenCV's plumb_bob distortion; k = fx fy cx cy k1 k2 p1 p2 k3.
template <typename T>
void projectPoint(const T* k, const T* p, T* uv) {
  const T x = p[0] / p[2], y = p[1] / p[2];
  const T r2 = x * x + y * y;
  const T radial = T(1) + k[4] * r2 + k[5] * r2 * r2 + k[8] * r2 * r2 * r2;
  const T xd = x * radial + T(2) * k[6] * x * y + k[7] * (r2 + T(2) * x * x);
  const T yd = y * radial + k[6] * (r2 + T(2) * y * y) + T(2) * k[7] * x * y;
  uv[0] = k[0] * xd + k[2];
  uv[1] = k[1] * yd + k[3];
}

/// p_camera of a target point, from T_world_camera and T_world_target (Pose6 each).
template <typename T>
void targetToCamera(const T* cam, const T* tgt, const Eigen::Vector3d& X, T* p_cam) {
  const T Xt[3] = {T(X.x()), T(X.y()), T(X.z())};
  T pw[3];
  ceres::AngleAxisRotatePoint(tgt, Xt, pw);
  for (int i = 0; i < 3; ++i) pw[i] += tgt[3 + i] - cam[3 + i];
  const T inv[3] = {-cam[0], -cam[1], -cam[2]};
  ceres::AngleAxisRotatePoint(inv, pw, p_cam);
}

struct CornerResidual {
  Eigen::Vector3d X;
  Eigen::Vector2d uv;
  double sigma;
  template <typename T>
  bool operator()(const T* cam, const T* tgt, const T* k, T* r) const {
    T p[3], proj[2];
    targetToCamera(cam, tgt, X, p);
    if (p[2] <= T(1e-6)) return false;
    projectPoint(k, p, proj);
    r[0] = (proj[0] - uv.x()) / sigma;
    r[1] = (proj[1] - uv.y()) / sigma;
    return true;
  }
};

/// A depth sample's error in the depth it read [in sigmas]: z_meas against the depth the camera
/// would read where its pixel's ray (x, y, 1), undistorted, meets the target plane:
/// scale * z_plane + offset (the rig file's convention). In the measured depth, not in the
/// corrected one: dividing the read depth's noise by the scale would let a larger scale shrink
/// it, which biased the scale by +0.1-0.18 % (and the offsets by -2..-8 mm) on the simulator's
/// calibration scene (seed 72) at Kinect v2 noise; with the noise off it was 0.01 %. In the
/// measured depth the same scene gives 0.03-0.05 % on seeds 72, 74, 75.
struct DepthResidual {
  Eigen::Vector3d ray;
  double z_meas;
  Eigen::Matrix3d R_cd;
  Eigen::Vector3d t_cd;
  double sigma;
  template <typename T>
  bool operator()(const T* cam, const T* tgt, const T* depth, T* r) const {
    // The ray and the depth camera's origin in the world.
    const T dir_c[3] = {T(R_cd(0, 0) * ray.x() + R_cd(0, 1) * ray.y() + R_cd(0, 2)),
                        T(R_cd(1, 0) * ray.x() + R_cd(1, 1) * ray.y() + R_cd(1, 2)),
                        T(R_cd(2, 0) * ray.x() + R_cd(2, 1) * ray.y() + R_cd(2, 2))};
    const T org_c[3] = {T(t_cd(0)), T(t_cd(1)), T(t_cd(2))};
    T dir_w[3], org_w[3];
    ceres::AngleAxisRotatePoint(cam, dir_c, dir_w);
    ceres::AngleAxisRotatePoint(cam, org_c, org_w);
    for (int i = 0; i < 3; ++i) org_w[i] += cam[3 + i];
    // The target plane: normal n (its z axis in the world) through its origin.
    const T ez[3] = {T(0), T(0), T(1)};
    T n[3];
    ceres::AngleAxisRotatePoint(tgt, ez, n);
    const T denom = n[0] * dir_w[0] + n[1] * dir_w[1] + n[2] * dir_w[2];
    if (ceres::abs(denom) < T(1e-6)) return false;
    const T z_plane = (n[0] * (tgt[3] - org_w[0]) + n[1] * (tgt[4] - org_w[1]) +
                       n[2] * (tgt[5] - org_w[2])) /
                      denom;
    r[0] = (T(z_meas) - (depth[1] * z_plane + depth[0])) / sigma;
    return true;
  }
};

// ---------------------------------------------------------------------------------------------
// Preparation: usable observations with their PnP poses.

struct Obs {
  int camera = 0;
  int placement = 0;
  double stamp = 0.0;
  std::vector<CornerObservation> corners;
  std::vector<Eigen::Vector3d> rays;  ///< undistorted depth rays (x, y, 1)
  std::vector<double> z;              ///< their measured depths
  std::vector<double> sigma;          ///< their noise [m] (0: the solver's default)
  Eigen::Isometry3d T_cam_target = Eigen::Isometry3d::Identity();  ///< PnP
  bool reversed = false;
  bool rejected = false;
};

std::array<double, 9> intrinsicsArray(const Intrinsics& k) {
  return {k.fx, k.fy, k.cx, k.cy, k.D[0], k.D[1], k.D[2], k.D[3], k.D[4]};
}

cv::Mat cameraMatrix(const Intrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

bool solvePnP(const std::vector<CornerObservation>& corners, const std::vector<Eigen::Vector3d>& X,
              const Intrinsics& k, Eigen::Isometry3d* T) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (const auto& c : corners) {
    obj.emplace_back(X[c.id].x(), X[c.id].y(), X[c.id].z());
    img.emplace_back(c.uv.x(), c.uv.y());
  }
  cv::Mat rvec, tvec;
  const cv::Mat K = cameraMatrix(k), D(k.D);
  if (!cv::solvePnP(obj, img, K, D, rvec, tvec, false, cv::SOLVEPNP_IPPE)) return false;
  cv::solvePnPRefineLM(obj, img, K, D, rvec, tvec);
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  *T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) T->linear()(i, j) = R.at<double>(i, j);
    T->translation()(i) = tvec.at<double>(i);
  }
  return T->translation().z() > 0;
}

std::vector<Eigen::Vector3d> undistortedRays(const std::vector<DepthSample>& samples,
                                             const Intrinsics& k) {
  std::vector<cv::Point2d> px, out;
  for (const auto& s : samples) px.emplace_back(s.u, s.v);
  std::vector<Eigen::Vector3d> rays;
  if (px.empty()) return rays;
  cv::undistortPoints(px, out, cameraMatrix(k), cv::Mat(k.D));
  for (const auto& p : out) rays.emplace_back(p.x, p.y, 1.0);
  return rays;
}

std::vector<Obs> prepare(const ObservationSet& set, const std::vector<Eigen::Vector3d>& X,
                         const SolverOptions& opt, CalibrationResult* result) {
  std::vector<Obs> out;
  for (const Observation& o : set.observations) {
    const int c = set.findCamera(o.camera);
    const CameraSetup& cam = set.cameras[c];
    auto reject = [&](const std::string& why) {
      result->rejected.push_back({o.camera, o.placement, why});
    };
    Obs ob;
    ob.camera = c;
    ob.placement = o.placement;
    ob.stamp = o.stamp;
    std::set<int> ids;
    bool bad_id = false;
    for (const auto& corner : o.corners) {
      if (corner.id < 0 || corner.id >= static_cast<int>(X.size()) || !ids.insert(corner.id).second)
        bad_id = true;
      ob.corners.push_back(corner);
    }
    if (bad_id) {
      reject("a corner id is out of range or repeated (a wrongly decoded target?)");
      continue;
    }
    if (static_cast<int>(ob.corners.size()) < opt.min_corners) {
      reject("only " + std::to_string(ob.corners.size()) + " corners (at least " +
             std::to_string(opt.min_corners) + " needed)");
      continue;
    }
    if (!solvePnP(ob.corners, X, cam.intrinsics, &ob.T_cam_target)) {
      reject("no target pose from its corners (PnP failed)");
      continue;
    }
    if (opt.estimate_depth_offset && cam.depth_intrinsics && !o.depth.empty()) {
      ob.rays = undistortedRays(o.depth, *cam.depth_intrinsics);
      for (const auto& s : o.depth) ob.z.push_back(s.z), ob.sigma.push_back(s.sigma);
    }
    out.push_back(std::move(ob));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The first rig: breadth first from the anchor.

/// The candidate pose most others agree with (within 0.25 m and 3 deg: single-observation PnP
/// poses of a 1.2 m board at 7 m scatter by centimetres and tenths of a degree, a wrong
/// observation by far more).
Eigen::Isometry3d consensus(const std::vector<Eigen::Isometry3d>& candidates) {
  size_t best = 0;
  int best_votes = -1;
  for (size_t i = 0; i < candidates.size(); ++i) {
    int votes = 0;
    for (const auto& other : candidates)
      if ((other.translation() - candidates[i].translation()).norm() < 0.25 &&
          rotationAngle(other.linear().transpose() * candidates[i].linear()) < 3.0 * M_PI / 180)
        ++votes;
    if (votes > best_votes) best_votes = votes, best = i;
  }
  return candidates[best];
}

struct InitialRig {
  std::vector<std::optional<Eigen::Isometry3d>> camera;     ///< T_world_camera
  std::map<int, Eigen::Isometry3d> placement;                ///< T_world_target
};

InitialRig initialRig(const ObservationSet& set, const std::vector<Obs>& obs, bool symmetric) {
  InitialRig rig;
  rig.camera.resize(set.cameras.size());
  if (set.anchor.camera)
    rig.camera[set.findCamera(*set.anchor.camera)] = set.anchor.T_world_anchor;
  else
    rig.placement[*set.anchor.placement] = set.anchor.T_world_anchor;
  for (bool grew = true; grew;) {
    grew = false;
    for (size_t c = 0; c < set.cameras.size(); ++c) {
      if (rig.camera[c]) continue;
      std::vector<Eigen::Isometry3d> cands;
      for (const Obs& o : obs)
        if (o.camera == static_cast<int>(c) && rig.placement.count(o.placement)) {
          const Eigen::Isometry3d& Twt = rig.placement.at(o.placement);
          cands.push_back(Twt * o.T_cam_target.inverse());
          if (symmetric) cands.push_back(Twt * (o.T_cam_target * halfTurn()).inverse());
        }
      if (cands.empty()) continue;
      // One camera at a time, so that the next one sees the placements this one brings and
      // votes among many (a chessboard's anchor seen in reversed order by a second camera would
      // otherwise tie).
      rig.camera[c] = consensus(cands);
      grew = true;
      break;
    }
    std::map<int, std::vector<Eigen::Isometry3d>> cands;
    for (const Obs& o : obs)
      if (!rig.placement.count(o.placement) && rig.camera[o.camera])
        cands[o.placement].push_back(*rig.camera[o.camera] * o.T_cam_target);
    for (const auto& [p, list] : cands) rig.placement[p] = consensus(list), grew = true;
  }
  return rig;
}

/// For a chessboard: reverse the corner order of every observation whose half-turned pose agrees
/// better with the first rig; a placement most of whose observations would be reversed is turned
/// instead (except the anchor, which is fixed). Returns how many observations were reversed.
int resolveReversal(const ObservationSet& set, const std::vector<Eigen::Vector3d>& X,
                    InitialRig* rig, std::vector<Obs>* obs) {
  std::map<int, std::vector<Obs*>> by_placement;
  for (Obs& o : *obs)
    if (rig->camera[o.camera] && rig->placement.count(o.placement))
      by_placement[o.placement].push_back(&o);
  const int n = static_cast<int>(X.size());
  int reversed = 0;
  for (auto& [p, list] : by_placement) {
    std::vector<bool> turn;
    for (const Obs* o : list) {
      const Eigen::Isometry3d expected = rig->camera[o->camera]->inverse() * rig->placement.at(p);
      const Eigen::Matrix3d Rt = expected.linear().transpose();
      turn.push_back(rotationAngle(Rt * (o->T_cam_target * halfTurn()).linear()) <
                     rotationAngle(Rt * o->T_cam_target.linear()));
    }
    const size_t turned = std::count(turn.begin(), turn.end(), true);
    if (2 * turned > list.size() && !(set.anchor.placement && *set.anchor.placement == p)) {
      rig->placement[p] = rig->placement[p] * halfTurn();
      turn.flip();
    }
    for (size_t i = 0; i < list.size(); ++i) {
      if (!turn[i]) continue;
      for (auto& c : list[i]->corners) c.id = n - 1 - c.id;
      list[i]->T_cam_target = list[i]->T_cam_target * halfTurn();
      list[i]->reversed = true;
      ++reversed;
    }
  }
  return reversed;
}

// ---------------------------------------------------------------------------------------------
// The joint solve.

struct Blocks {
  std::vector<Pose6> camera;
  std::map<int, Pose6> target;
  std::vector<std::array<double, 2>> depth;      ///< offset, scale
  std::vector<std::array<double, 9>> intrinsics;
};

void buildProblem(const ObservationSet& set, const std::vector<Obs>& obs,
                  const std::vector<Eigen::Vector3d>& X, const SolverOptions& opt, Blocks* b,
                  ceres::Problem* problem) {
  for (const Obs& o : obs) {
    if (o.rejected) continue;
    double* cam = b->camera[o.camera].data();
    double* tgt = b->target.at(o.placement).data();
    double* k = b->intrinsics[o.camera].data();
    for (const auto& c : o.corners) {
      auto* cost = new ceres::AutoDiffCostFunction<CornerResidual, 2, 6, 6, 9>(
          new CornerResidual{X[c.id], c.uv, opt.corner_sigma_px});
      problem->AddResidualBlock(cost, opt.robust ? new ceres::HuberLoss(3.0) : nullptr, cam, tgt, k);
    }
    const CameraSetup& setup = set.cameras[o.camera];
    for (size_t i = 0; i < o.rays.size(); ++i) {
      auto* cost = new ceres::AutoDiffCostFunction<DepthResidual, 1, 6, 6, 2>(
          new DepthResidual{o.rays[i], o.z[i], setup.T_camera_depth.linear(),
                            setup.T_camera_depth.translation(),
                            o.sigma[i] > 0 ? o.sigma[i] : opt.depth_sigma});
      problem->AddResidualBlock(cost, opt.robust ? new ceres::HuberLoss(3.0) : nullptr, cam, tgt,
                                b->depth[o.camera].data());
    }
  }
  for (size_t c = 0; c < b->camera.size(); ++c) {
    if (problem->HasParameterBlock(b->intrinsics[c].data()) && !opt.estimate_intrinsics)
      problem->SetParameterBlockConstant(b->intrinsics[c].data());
    double* depth = b->depth[c].data();
    if (!problem->HasParameterBlock(depth)) continue;
    if (!opt.estimate_depth_scale) {
      problem->SetManifold(depth, new ceres::SubsetManifold(2, {1}));
    }
  }
  if (set.anchor.camera) {
    double* cam = b->camera[set.findCamera(*set.anchor.camera)].data();
    if (problem->HasParameterBlock(cam)) problem->SetParameterBlockConstant(cam);
  } else if (b->target.count(*set.anchor.placement)) {
    double* tgt = b->target.at(*set.anchor.placement).data();
    if (problem->HasParameterBlock(tgt)) problem->SetParameterBlockConstant(tgt);
  }
}

void solve(ceres::Problem* problem) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = 100;
  so.num_threads = 2;
  so.function_tolerance = 1e-10;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem, &summary);
}

/// Corner residuals [px] of one observation at the current blocks.
std::vector<double> cornerErrors(const Obs& o, const std::vector<Eigen::Vector3d>& X,
                                 const Blocks& b) {
  std::vector<double> err;
  for (const auto& c : o.corners) {
    CornerResidual r{X[c.id], c.uv, 1.0};
    double res[2] = {1e9, 1e9};  // behind the camera: a huge error
    r(b.camera[o.camera].data(), b.target.at(o.placement).data(), b.intrinsics[o.camera].data(),
      res);
    err.push_back(std::hypot(res[0], res[1]));
  }
  return err;
}

std::vector<double> depthErrors(const Obs& o, const CameraSetup& setup, const Blocks& b) {
  std::vector<double> err;
  for (size_t i = 0; i < o.rays.size(); ++i) {
    DepthResidual r{o.rays[i], o.z[i], setup.T_camera_depth.linear(),
                    setup.T_camera_depth.translation(), 1.0};
    double res = 0.0;  // a ray along the plane: no error taken
    r(b.camera[o.camera].data(), b.target.at(o.placement).data(), b.depth[o.camera].data(), &res);
    err.push_back(res);
  }
  return err;
}

/// The amplitude samples of camera c against the solved model, grouped by placement (the frames
/// of one placement share its solved plane, and so its error).
std::vector<WeakReturnSample> amplitudeResiduals(const ObservationSet& set, size_t c,
                                                 const Blocks& b,
                                                 const std::vector<RejectedObservation>& rejected) {
  std::vector<WeakReturnSample> out;
  const CameraSetup& setup = set.cameras[c];
  if (!setup.depth_intrinsics) return out;
  for (const Observation& o : set.observations) {
    if (o.camera != setup.name || o.amplitude.empty() || !b.target.count(o.placement)) continue;
    if (std::any_of(rejected.begin(), rejected.end(), [&](const RejectedObservation& r) {
          return r.camera == o.camera && r.placement == o.placement;
        }))
      continue;
    std::vector<DepthSample> px;
    for (const AmplitudeSample& a : o.amplitude) px.push_back({a.u, a.v, a.z, 0.0});
    const std::vector<Eigen::Vector3d> rays = undistortedRays(px, *setup.depth_intrinsics);
    const std::array<double, 2> plain = {0.0, 1.0};  // z_meas - z_plane
    for (size_t i = 0; i < rays.size(); ++i) {
      DepthResidual r{rays[i], o.amplitude[i].z, setup.T_camera_depth.linear(),
                      setup.T_camera_depth.translation(), 1.0};
      double e = 0.0;
      if (!r(b.camera[c].data(), b.target.at(o.placement).data(), plain.data(), &e)) continue;
      const double z_plane = o.amplitude[i].z - e;
      const double model = b.depth[c][1] * z_plane + b.depth[c][0];
      out.push_back({o.placement, o.amplitude[i].amplitude, o.amplitude[i].z - model});
    }
  }
  return out;
}

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / v.size());
}

/// After the first solve: drop far-off corners and depth samples, reject observations that
/// disagree as a whole.
void pruneOutliers(const ObservationSet& set, const std::vector<Eigen::Vector3d>& X,
                   const SolverOptions& opt, const Blocks& b, std::vector<Obs>* obs,
                   CalibrationResult* result) {
  // A camera's typical observation rms: when all its observations are off (intrinsics that do
  // not belong to its images), none is an outlier, and the final check names the camera.
  std::vector<std::vector<double>> per_camera(set.cameras.size());
  for (const Obs& o : *obs)
    if (!o.rejected) per_camera[o.camera].push_back(rms(cornerErrors(o, X, b)));
  std::vector<double> typical(set.cameras.size(), 0.0);
  for (size_t c = 0; c < per_camera.size(); ++c)
    typical[c] = upperMedian(per_camera[c]);
  for (Obs& o : *obs) {
    if (o.rejected) continue;
    const std::vector<double> err = cornerErrors(o, X, b);
    const double r = rms(err);
    const std::string& name = set.cameras[o.camera].name;
    if (r > std::max(opt.max_observation_rms_px, 3.0 * typical[o.camera])) {
      o.rejected = true;
      result->rejected.push_back(
          {name, o.placement,
           "corners disagree with the calibrated rig (rms " + std::to_string(r) +
               " px): the target moved during the frame, or a corner was misdetected"});
      continue;
    }
    std::vector<CornerObservation> kept;
    for (size_t i = 0; i < err.size(); ++i)
      if (err[i] <= std::max(opt.max_corner_residual_px, 3.0 * typical[o.camera]))
        kept.push_back(o.corners[i]);
    result->dropped_corners += static_cast<int>(o.corners.size() - kept.size());
    o.corners = kept;
    if (static_cast<int>(o.corners.size()) < opt.min_corners) {
      o.rejected = true;
      result->rejected.push_back({name, o.placement, "too few corners left after outliers"});
      continue;
    }
    // Depth samples beyond 4 sigma of the camera's own spread: mixed pixels at the target's
    // edge, or something in front of it.
    std::vector<double> d = depthErrors(o, set.cameras[o.camera], b);
    for (size_t i = 0; i < d.size(); ++i) d[i] /= o.sigma[i] > 0 ? o.sigma[i] : opt.depth_sigma;
    const double limit = 4.0 * std::max(rms(d), 1e-2);
    Obs inliers;
    for (size_t i = 0; i < d.size(); ++i)
      if (std::abs(d[i]) <= limit)
        inliers.rays.push_back(o.rays[i]), inliers.z.push_back(o.z[i]),
            inliers.sigma.push_back(o.sigma[i]);
    o.rays = inliers.rays;
    o.z = inliers.z;
    o.sigma = inliers.sigma;
  }
}

void checkCoverage(const ObservationSet& set, const std::vector<Obs>& obs, const InitialRig& rig,
                   const SolverOptions& opt) {
  std::vector<std::set<int>> seen(set.cameras.size());
  for (const Obs& o : obs)
    if (!o.rejected) seen[o.camera].insert(o.placement);
  std::vector<int> count;
  for (const auto& s : seen) count.push_back(static_cast<int>(s.size()));
  for (size_t c = 0; c < set.cameras.size(); ++c)
    if (count[c] < opt.min_placements)
      fail("camera ", set.cameras[c].name, ": saw the target in ", count[c],
           " usable placements; at least ", opt.min_placements,
           " are needed: record more placements in its view");
  std::string missing;
  for (size_t c = 0; c < set.cameras.size(); ++c)
    if (!rig.camera[c]) missing += (missing.empty() ? "" : ", ") + set.cameras[c].name;
  if (!missing.empty())
    fail("cameras ", missing,
         " share no chain of placements with the anchor (",
         set.anchor.camera ? "camera " + *set.anchor.camera
                           : "placement " + std::to_string(*set.anchor.placement),
         "): the cameras must form one connected graph of shared placements; record placements "
         "that they see together with an already connected camera");
}

}  // namespace

/// One solve (calibrate runs it again when a camera's own weak-return law differs).
CalibrationResult calibrateOnce(const ObservationSet& set, const SolverOptions& opt);

namespace {

/// The set with the depth samples of each camera whose own weak-return law `result` fitted
/// corrected again with that law instead of the sensor's (the capture's): z + (B0 - B) (h(a) -
/// h(a_min)), a the sample's amplitude. Null when no camera has a law of its own.
std::optional<ObservationSet> withCamerasOwnLaws(const ObservationSet& set,
                                                 const CalibrationResult& result) {
  const kinect_v2::AmplitudeModel sensor;
  std::map<std::string, double> delta;  // camera -> B0 - B
  for (const CameraResult& c : result.cameras)
    if (c.weak_return.fitted) delta[c.name] = sensor.bias_coeff - c.weak_return.coeff;
  if (delta.empty()) return std::nullopt;
  ObservationSet again = set;
  bool changed = false;
  for (Observation& o : again.observations) {
    const auto d = delta.find(o.camera);
    if (d == delta.end()) continue;
    const double floor_shape = kinect_v2::weakReturnShape(sensor, sensor.bias_min_amplitude);
    for (DepthSample& s : o.depth) {
      if (!(s.amplitude > 0)) continue;
      s.z += d->second * (kinect_v2::weakReturnShape(sensor, s.amplitude) - floor_shape);
      changed = true;
    }
  }
  if (!changed) return std::nullopt;
  return again;
}

}  // namespace

CalibrationResult calibrate(const ObservationSet& set, const SolverOptions& opt) {
  CalibrationResult first = calibrateOnce(set, opt);
  if (!(opt.fit_weak_return && opt.estimate_depth_offset)) return first;
  // The solve's depth samples were corrected with the sensor's law; where a camera's own differs,
  // they carry the difference into its offset and, through the planes, into every pose (four
  // cameras 3.5 m up at 1.5x the sensor's B: positions 4.3-4.5 mm off). Solve again with each
  // camera's own law.
  const std::optional<ObservationSet> again = withCamerasOwnLaws(set, first);
  if (!again) return first;
  CalibrationResult second = calibrateOnce(*again, opt);
  second.seconds += first.seconds;
  return second;
}

CalibrationResult calibrateOnce(const ObservationSet& set, const SolverOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  validateTarget(set.target, "calibration target");
  const std::vector<Eigen::Vector3d> X = targetCorners(set.target);
  CalibrationResult result;
  std::vector<Obs> obs = prepare(set, X, opt, &result);
  if (set.anchor.placement) {
    bool seen = false;
    for (const Obs& o : obs) seen |= o.placement == *set.anchor.placement;
    if (!seen)
      fail("anchor placement ", *set.anchor.placement,
           " was not seen by any camera (with enough corners): the world frame is undefined");
  }
  const bool symmetric = set.target.type == TargetGeometry::Type::kChessboard;
  InitialRig rig = initialRig(set, obs, symmetric);
  checkCoverage(set, obs, rig, opt);
  if (symmetric) result.reversed_observations = resolveReversal(set, X, &rig, &obs);

  Blocks b;
  for (size_t c = 0; c < set.cameras.size(); ++c) {
    b.camera.push_back(toPose6(*rig.camera[c]));
    b.depth.push_back({0.0, 1.0});
    b.intrinsics.push_back(intrinsicsArray(set.cameras[c].intrinsics));
  }
  for (const auto& [p, T] : rig.placement) b.target[p] = toPose6(T);
  for (int pass = 0; pass < 2; ++pass) {
    ceres::Problem problem;
    buildProblem(set, obs, X, opt, &b, &problem);
    solve(&problem);
    if (pass == 0 && !opt.robust) break;
    if (pass == 0) pruneOutliers(set, X, opt, b, &obs, &result);
  }
  checkCoverage(set, obs, rig, opt);

  double all = 0;
  int n_all = 0;
  for (size_t c = 0; c < set.cameras.size(); ++c) {
    CameraResult cr;
    cr.name = set.cameras[c].name;
    cr.T_world_camera = fromPose6(b.camera[c]);
    cr.depth_offset = b.depth[c][0];
    cr.depth_scale = b.depth[c][1];
    cr.intrinsics = set.cameras[c].intrinsics;
    const auto& k = b.intrinsics[c];
    cr.intrinsics.fx = k[0], cr.intrinsics.fy = k[1], cr.intrinsics.cx = k[2], cr.intrinsics.cy = k[3];
    cr.intrinsics.D = {k[4], k[5], k[6], k[7], k[8]};
    std::vector<double> ce, de;
    std::set<int> placements;
    for (const Obs& o : obs) {
      if (o.rejected || o.camera != static_cast<int>(c)) continue;
      placements.insert(o.placement);
      ++cr.observations;
      for (double e : cornerErrors(o, X, b)) ce.push_back(e);
      for (double e : depthErrors(o, set.cameras[c], b)) de.push_back(e);
    }
    cr.placements = static_cast<int>(placements.size());
    cr.corners = static_cast<int>(ce.size());
    cr.depth_samples = static_cast<int>(de.size());
    cr.corner_rms_px = rms(ce);
    cr.depth_rms = rms(de);
    if (opt.fit_weak_return && opt.estimate_depth_offset) {
      const std::vector<WeakReturnSample> samples =
          amplitudeResiduals(set, c, b, result.rejected);
      if (!samples.empty())
        cr.weak_return = fitWeakReturnBias(samples, kinect_v2::AmplitudeModel{}, opt.weak_return);
    }
    for (double e : ce) all += e * e, ++n_all;
    if (cr.corner_rms_px > opt.max_camera_rms_px)
      fail("camera ", cr.name, ": corner reprojection rms ", cr.corner_rms_px,
           " px after calibration (at most ", opt.max_camera_rms_px,
           " expected): its intrinsics (fx ", cr.intrinsics.fx, ", ", cr.intrinsics.width, "x",
           cr.intrinsics.height, ") do not match the images its corners were found in");
    result.cameras.push_back(cr);
  }
  result.corner_rms_px = n_all ? std::sqrt(all / n_all) : 0.0;
  int max_p = 0;
  for (const auto& kv : b.target) max_p = std::max(max_p, kv.first + 1);
  result.T_world_target.assign(max_p, Eigen::Isometry3d::Identity());
  for (const auto& [p, pose] : b.target) result.T_world_target[p] = fromPose6(pose);
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

RigCalibration CalibrationResult::rig(const ObservationSet& set) const {
  RigCalibration rig;
  rig.world_frame = set.world_frame;
  for (size_t c = 0; c < cameras.size(); ++c) {
    CameraCalibration cc;
    cc.name = cameras[c].name;
    cc.sensor = set.cameras[c].sensor;
    cc.T_world_link = cameras[c].T_world_camera;
    cc.depth_offset = cameras[c].depth_offset;
    cc.depth_scale = cameras[c].depth_scale;
    if (cameras[c].weak_return.fitted) {
      cc.weak_return_bias = cameras[c].weak_return.coeff;
      cc.depth_offset += cameras[c].weak_return.offset_shift;
    }
    rig.cameras.push_back(cc);
  }
  return rig;
}

RigComparison compareRigs(const RigCalibration& estimate, const RigCalibration& truth) {
  // The aligning rotation: the chordal mean of R_true R_est^T; its translation: the mean of
  // p_true - R p_est. Both least squares (over orientations, then positions).
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  std::vector<std::pair<const CameraCalibration*, const CameraCalibration*>> pairs;
  for (const auto& e : estimate.cameras) {
    const int t = truth.find(e.name);
    if (t < 0) fail("camera ", e.name, " is in the calibrated rig but not in the true rig");
    pairs.emplace_back(&e, &truth.cameras[t]);
    M += truth.cameras[t].T_world_link.linear() * e.T_world_link.linear().transpose();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1;
    R = U * svd.matrixV().transpose();
  }
  Eigen::Vector3d t = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
  for (const auto& [e, tr] : pairs) {
    t += tr->T_world_link.translation() - R * e->T_world_link.translation();
    centre += tr->T_world_link.translation();
  }
  t /= static_cast<double>(pairs.size());
  centre /= static_cast<double>(pairs.size());
  Eigen::Isometry3d A = Eigen::Isometry3d::Identity();
  A.linear() = R;
  A.translation() = t;
  RigComparison out;
  // Anchoring error: how far the alignment moves the rig's centre, and its angle.
  out.anchor_translation = (A * centre - centre).norm();
  out.anchor_rotation = rotationAngle(R);
  for (const auto& [e, tr] : pairs) {
    RigComparison::Camera c;
    c.name = e->name;
    const Eigen::Isometry3d aligned = A * e->T_world_link;
    c.translation_error = (aligned.translation() - tr->T_world_link.translation()).norm();
    c.rotation_error = rotationAngle(tr->T_world_link.linear().transpose() * aligned.linear());
    c.raw_translation_error =
        (e->T_world_link.translation() - tr->T_world_link.translation()).norm();
    c.raw_rotation_error =
        rotationAngle(tr->T_world_link.linear().transpose() * e->T_world_link.linear());
    c.depth_offset_error = e->depth_offset - tr->depth_offset;
    c.depth_scale_error = e->depth_scale - tr->depth_scale;
    out.cameras.push_back(c);
  }
  return out;
}

}  // namespace drill_pipe_pose::calibration
