#include "drill_pipe_pose/core/estimator/thesis_baseline.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>

#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
using Cloud = pcl::PointCloud<pcl::PointXYZ>;
}  // namespace

struct ThesisBaseline::Impl {
  EstimatorConfig config;
  std::array<Cloud::Ptr, kNumEnds> models;
  std::array<Eigen::Vector3f, kNumEnds> model_centroid;
  std::array<std::deque<Cloud::Ptr>, kNumEnds> layers;
  std::array<bool, kNumEnds> has_pose{{false, false}};
  std::array<Eigen::Matrix4f, kNumEnds> pose;  ///< T_world_model of the last cycle

  /// Step 4: label l's model pre-aligned (translated onto seg's centroid unless last cycle's
  /// pose still lies within baseline.prealign_distance) and registered to seg by ICP,
  /// baseline.icp_runs x icp_iterations. Keeps the result as the next cycle's start; false
  /// when ICP did not converge or gave a non-finite transform.
  bool align(int l, const Cloud::Ptr& seg, Eigen::Matrix4f* T, double* fitness);
};

ThesisBaseline::ThesisBaseline(const EstimatorConfig& config) : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  for (int l = 0; l < kNumEnds; ++l) {
    // Uniformly sampled model surface (CloudCompare-style: every surface, bore included).
    const auto surf = sampleProfileSurface(toolJointProfile(static_cast<EndLabel>(l), config.dims),
                                           config.baseline.model_spacing, 1, false);
    Cloud::Ptr m(new Cloud);
    Eigen::Vector3f c = Eigen::Vector3f::Zero();
    for (const auto& s : surf) {
      m->push_back(pcl::PointXYZ(s.p.x(), s.p.y(), s.p.z()));
      c += s.p;
    }
    impl_->model_centroid[l] = c / std::max<size_t>(1, surf.size());
    impl_->models[l] = m;
    impl_->pose[l].setIdentity();
  }
}

ThesisBaseline::~ThesisBaseline() = default;

void ThesisBaseline::reset() {
  for (int l = 0; l < kNumEnds; ++l) {
    impl_->layers[l].clear();
    impl_->has_pose[l] = false;
    impl_->pose[l].setIdentity();
  }
}

namespace {

/// Step 1, the cut-out: each box mapped to depth pixels by the focal-length ratio about the
/// principal points; the points inside the range and the work zone, per label, in the world
/// frame. *cam_names: per label, the cameras that boxed it.
std::array<Cloud::Ptr, kNumEnds> cutOutByFocalRatio(
    const std::vector<CycleCamera>& cams, const EstimatorConfig& cfg,
    std::array<std::vector<std::string>, kNumEnds>* cam_names) {
  std::array<Cloud::Ptr, kNumEnds> cycle{{Cloud::Ptr(new Cloud), Cloud::Ptr(new Cloud)}};
  for (const CycleCamera& cam : cams) {
    const DepthProjector proj(cam.depth);
    const double sx = cam.depth.fx() / cam.color.fx(), sy = cam.depth.fy() / cam.color.fy();
    auto to_du = [&](double u) {
      return (u + cam.color.offsetX() - cam.color.cx()) * sx + cam.depth.cx() - cam.depth.offsetX();
    };
    auto to_dv = [&](double v) {
      return (v + cam.color.offsetY() - cam.color.cy()) * sy + cam.depth.cy() - cam.depth.offsetY();
    };
    const Eigen::Isometry3f T = cam.T_world_depth.cast<float>();
    for (const DetectionBox& b : cam.boxes) {
      const int l = static_cast<int>(b.label);
      auto& names = (*cam_names)[l];
      if (std::find(names.begin(), names.end(), cam.name) == names.end())
        names.push_back(cam.name);
      // Clamped to +-1e9 px before the conversion to int (a box far off the image is no int).
      auto px = [](double x) { return static_cast<int>(std::clamp(x, -1e9, 1e9)); };
      const int u0 = px(std::floor(to_du(b.x_min)));
      const int u1 = px(std::ceil(to_du(b.x_max))) + 1;
      const int v0 = px(std::floor(to_dv(b.y_min)));
      const int v1 = px(std::ceil(to_dv(b.y_max))) + 1;
      proj.forEachPoint(cam.image, u0, v0, u1, v1, [&](int, int, const Eigen::Vector3f& p) {
        if (p.z() < cfg.cutout.min_range || p.z() > cfg.cutout.max_range) return;
        const Eigen::Vector3f w = T * p;
        if ((w.array() < cfg.work_zone.min.cast<float>().array()).any() ||
            (w.array() > cfg.work_zone.max.cast<float>().array()).any())
          return;
        cycle[l]->push_back(pcl::PointXYZ(w.x(), w.y(), w.z()));
      });
    }
  }
  return cycle;
}

/// Step 3, the segmentation: the square of side bl.square_size about the centroid (x, y) of the
/// fused points in the height band. *in_band: how many points the band held.
Cloud::Ptr squareExclusion(const Cloud& fused, const EstimatorConfig::Baseline& bl,
                           size_t* in_band) {
  double sx = 0, sy = 0;
  size_t n = 0;
  for (const auto& p : fused)
    if (p.z >= bl.band_min_z && p.z <= bl.band_max_z) {
      sx += p.x;
      sy += p.y;
      ++n;
    }
  Cloud::Ptr seg(new Cloud);
  if (n > 0) {
    const double cx = sx / n, cy = sy / n, h = bl.square_size / 2;
    for (const auto& p : fused)
      if (std::abs(p.x - cx) <= h && std::abs(p.y - cy) <= h) seg->push_back(p);
  }
  *in_band = n;
  return seg;
}

}  // namespace

bool ThesisBaseline::Impl::align(int l, const Cloud::Ptr& seg, Eigen::Matrix4f* T_out,
                                 double* fitness) {
  const auto& bl = config.baseline;
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
  for (const auto& p : *seg) c += p.getVector3fMap();
  c /= static_cast<float>(seg->size());
  Eigen::Matrix4f T = pose[l];
  const Eigen::Vector3f model_c = T.block<3, 3>(0, 0) * model_centroid[l] + T.block<3, 1>(0, 3);
  if (!has_pose[l] || (model_c - c).norm() > bl.prealign_distance) {
    T.setIdentity();  // model loaded at the origin, translated onto the cloud's centroid
    T.block<3, 1>(0, 3) = c - model_centroid[l];
  }
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputSource(models[l]);
  icp.setInputTarget(seg);
  icp.setMaximumIterations(bl.icp_iterations);
  Cloud aligned;
  bool converged = false;
  for (int r = 0; r < bl.icp_runs; ++r) {
    icp.align(aligned, T);
    converged = icp.hasConverged();
    T = icp.getFinalTransformation();
  }
  *fitness = icp.getFitnessScore();
  pose[l] = T;
  has_pose[l] = true;
  *T_out = T;
  return converged && T.allFinite();
}

// Follows the thesis's chapter 3.4 step by step, to be read beside it.
void ThesisBaseline::process(const std::vector<CycleCamera>& cams, CycleResult* result) {
  const EstimatorConfig& cfg = impl_->config;
  const auto& bl = cfg.baseline;
  // 1. Cut-out.
  auto t0 = Clock::now();
  std::array<std::vector<std::string>, kNumEnds> cam_names;
  const std::array<Cloud::Ptr, kNumEnds> cycle = cutOutByFocalRatio(cams, cfg, &cam_names);
  result->timing.cutout_ms = msSince(t0);

  // 2. Fusion: concatenate the last `layers` clouds per end.
  t0 = Clock::now();
  std::array<Cloud::Ptr, kNumEnds> fused;
  for (int l = 0; l < kNumEnds; ++l) {
    auto& q = impl_->layers[l];
    q.push_back(cycle[l]);
    while (static_cast<int>(q.size()) > bl.layers) q.pop_front();
    fused[l].reset(new Cloud);
    for (const auto& c : q) *fused[l] += *c;
    for (const auto& p : *fused[l]) result->fused.emplace_back(p.x, p.y, p.z);
  }
  result->timing.fusion_ms = msSince(t0);

  for (int l = 0; l < kNumEnds; ++l) {
    EndEstimate& e = result->ends[l];
    e.label = static_cast<EndLabel>(l);
    if (cycle[l]->empty()) {
      e.reason = std::string("no ") + labelName(e.label) + " points in this cycle";
      continue;
    }
    // 3. Square exclusion around the centroid of the points in the height band.
    t0 = Clock::now();
    size_t n = 0;
    const Cloud::Ptr seg = squareExclusion(*fused[l], bl, &n);
    result->timing.segmentation_ms += msSince(t0);
    if (seg->size() < bl.min_points) {
      e.reason = n == 0 ? "no points in the segmentation height band"
                        : "too few points in the segmentation square";
      continue;
    }
    for (const auto& p : *seg) result->segmented[l].emplace_back(p.x, p.y, p.z);

    // 4. Pre-alignment (translation to the centroid) and ICP, 10 x 200 iterations.
    t0 = Clock::now();
    Eigen::Matrix4f T;
    double fitness = 0;
    const bool converged = impl_->align(l, seg, &T, &fitness);
    result->timing.registration_ms += msSince(t0);
    if (!converged) {
      e.reason = "ICP did not converge";
      continue;
    }
    Eigen::Isometry3d T_world_model = Eigen::Isometry3d::Identity();
    T_world_model.matrix() = T.cast<double>();
    T_world_model.linear() =
        Eigen::Quaterniond(T_world_model.linear()).normalized().toRotationMatrix();
    e.valid = true;
    e.T_world_end = canonicalize(T_world_model);
    e.residual = std::sqrt(fitness);
    e.points = seg->size();
    e.cameras = cam_names[l];
    const Eigen::Matrix3d R = e.T_world_end.linear();
    e.covariance.setZero();
    e.covariance.block<3, 3>(0, 0) =
        Eigen::Matrix3d::Identity() * (bl.position_std * bl.position_std);
    e.covariance.block<3, 3>(3, 3) =
        R *
        Eigen::Vector3d(bl.tilt_std * bl.tilt_std, bl.tilt_std * bl.tilt_std,
                        cfg.covariance.roll_variance)
            .asDiagonal() *
        R.transpose();
  }
}

}  // namespace drill_pipe_pose
