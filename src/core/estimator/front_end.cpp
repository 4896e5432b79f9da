// The estimator configuration's method names and checks.

#include <algorithm>
#include <cmath>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/stages.hpp"

namespace drill_pipe_pose {

EstimatorMethod parseEstimatorMethod(const std::string& name, const std::string& source) {
  if (name == "ours") return EstimatorMethod::kOurs;
  if (name == "thesis_baseline") return EstimatorMethod::kThesisBaseline;
  fail(source, ": method = \"", name, "\" is not one of \"ours\", \"thesis_baseline\"");
}

const char* estimatorMethodName(EstimatorMethod m) {
  return m == EstimatorMethod::kOurs ? "ours" : "thesis_baseline";
}

void validateConfig(const EstimatorConfig& c) {
  auto finite_positive = [](double v, const char* key) {
    if (!(v > 0.0) || !std::isfinite(v)) fail("estimator config: ", key, " = ", v, " must be > 0");
  };
  auto non_negative = [](double v, const char* key) {
    if (!(v >= 0.0) || !std::isfinite(v))
      fail("estimator config: ", key, " = ", v, " must be >= 0");
  };
  auto at_least = [](double v, double min, const char* key) {
    if (!(v >= min)) fail("estimator config: ", key, " = ", v, " must be >= ", min);
  };
  for (int i = 0; i < 3; ++i)
    if (!(c.work_zone.min[i] < c.work_zone.max[i]))
      fail("estimator config: work_zone.min[", i, "] = ", c.work_zone.min[i],
           " must be < work_zone.max[", i, "] = ", c.work_zone.max[i]);
  // Throws naming the bad dimension.
  toolJointProfile(EndLabel::kBoxEnd, c.dims);
  toolJointProfile(EndLabel::kPinEnd, c.dims);
  non_negative(c.cutout.box_margin_px, "cutout.box_margin_px");
  finite_positive(c.cutout.min_range, "cutout.min_range");
  if (!(c.cutout.max_range > c.cutout.min_range))
    fail("estimator config: cutout.max_range = ", c.cutout.max_range,
         " must be > cutout.min_range = ", c.cutout.min_range);
  at_least(c.carving.min_cameras, 1, "carving.min_cameras");
  if (!(c.carving.vote_fraction >= 0.0 && c.carving.vote_fraction <= 1.0))
    fail("estimator config: carving.vote_fraction = ", c.carving.vote_fraction,
         " must be in [0, 1]");
  non_negative(c.carving.margin_px, "carving.margin_px");
  non_negative(c.carving.occlusion_margin, "carving.occlusion_margin");
  non_negative(c.carving.box_reach, "carving.box_reach");
  finite_positive(c.instances.cluster_tolerance, "instances.cluster_tolerance");
  at_least(c.instances.max_instances, 1, "instances.max_instances");
  finite_positive(c.instances.track_gate, "instances.track_gate");
  non_negative(c.instances.min_cost_margin, "instances.min_cost_margin");
  at_least(c.instances.min_decisions, 1, "instances.min_decisions");
  at_least(c.instances.memory_decisions, 1, "instances.memory_decisions");
  finite_positive(c.instances.memory_s, "instances.memory_s");
  non_negative(c.instances.radius_difference, "instances.radius_difference");
  at_least(c.axis_fit.min_points, 10, "axis_fit.min_points");
  at_least(c.axis_fit.max_points, 20, "axis_fit.max_points");
  if (c.profile_fit.max_points < c.axis_fit.min_points)
    fail("estimator config: profile_fit.max_points = ", c.profile_fit.max_points,
         " must be >= axis_fit.min_points");
  at_least(c.axis_fit.hypotheses, 0, "axis_fit.hypotheses");
  finite_positive(c.axis_fit.neighbourhood, "axis_fit.neighbourhood");
  finite_positive(c.axis_fit.inlier_threshold, "axis_fit.inlier_threshold");
  at_least(c.axis_fit.iterations, 1, "axis_fit.iterations");
  finite_positive(c.profile_fit.search_step, "profile_fit.search_step");
  finite_positive(c.profile_fit.truncation, "profile_fit.truncation");
  non_negative(c.profile_fit.wear_margin, "profile_fit.wear_margin");
  non_negative(c.profile_fit.support_clearance, "profile_fit.support_clearance");
  at_least(c.profile_fit.iterations, 1, "profile_fit.iterations");
  finite_positive(c.profile_fit.huber, "profile_fit.huber");
  non_negative(c.profile_fit.label_margin, "profile_fit.label_margin");
  at_least(c.profile_fit.search_points, 20, "profile_fit.search_points");
  finite_positive(c.profile_fit.max_rms, "profile_fit.max_rms");
  non_negative(c.profile_fit.min_inlier_fraction, "profile_fit.min_inlier_fraction");
  non_negative(c.profile_fit.incidence_noise, "profile_fit.incidence_noise");
  if (!(c.profile_fit.silhouette_min_inlier_fraction >= 0.0 &&
        c.profile_fit.silhouette_min_inlier_fraction <= 1.0))
    fail("estimator config: profile_fit.silhouette_min_inlier_fraction = ",
         c.profile_fit.silhouette_min_inlier_fraction, " must be in [0, 1]");
  non_negative(c.cutout.edge_jump, "cutout.edge_jump");
  finite_positive(c.profile_fit.max_axial_std, "profile_fit.max_axial_std");
  finite_positive(c.profile_fit.max_tilt_std, "profile_fit.max_tilt_std");
  at_least(c.axis_fit.plane_iterations, 0, "axis_fit.plane_iterations");
  finite_positive(c.axis_fit.plane_threshold, "axis_fit.plane_threshold");
  non_negative(c.axis_fit.plane_min_fraction, "axis_fit.plane_min_fraction");
  non_negative(c.axis_fit.plane_min_extent, "axis_fit.plane_min_extent");
  non_negative(c.free_space.pixel_weight, "free_space.pixel_weight");
  finite_positive(c.free_space.margin, "free_space.margin");
  finite_positive(c.free_space.sample_spacing, "free_space.sample_spacing");
  non_negative(c.free_space.tube_length, "free_space.tube_length");
  if (!(c.free_space.min_cos_incidence >= 0.0 && c.free_space.min_cos_incidence < 1.0))
    fail("estimator config: free_space.min_cos_incidence = ", c.free_space.min_cos_incidence,
         " must be in [0, 1)");
  non_negative(c.free_space.axial_range, "free_space.axial_range");
  finite_positive(c.free_space.decision_step, "free_space.decision_step");
  finite_positive(c.free_space.axial_step, "free_space.axial_step");
  non_negative(c.free_space.min_direction_margin, "free_space.min_direction_margin");
  if (!std::isfinite(c.free_space.min_axial_contrast))
    fail("estimator config: free_space.min_axial_contrast = ", c.free_space.min_axial_contrast,
         " must be finite");
  finite_positive(c.noise.scale, "noise.scale");
  finite_positive(c.noise.min_sigma, "noise.min_sigma");
  finite_positive(c.temporal.acceleration_density, "temporal.acceleration_density");
  finite_positive(c.temporal.tilt_rate_density, "temporal.tilt_rate_density");
  finite_positive(c.temporal.max_speed, "temporal.max_speed");
  finite_positive(c.temporal.gate_sigma, "temporal.gate_sigma");
  finite_positive(c.temporal.max_gap, "temporal.max_gap");
  at_least(c.temporal.confirmations, 0, "temporal.confirmations");
  at_least(c.threads, 1, "threads");
  at_least(c.tracking.redecide_every, 1, "tracking.redecide_every");
  finite_positive(c.tracking.max_gap, "tracking.max_gap");
  finite_positive(c.tracking.max_angle, "tracking.max_angle");
  finite_positive(c.tracking.max_offset, "tracking.max_offset");
  finite_positive(c.tracking.max_prediction, "tracking.max_prediction");
  at_least(c.profile_fit.coarse_points, 20, "profile_fit.coarse_points");
  at_least(c.profile_fit.polish_iterations, 1, "profile_fit.polish_iterations");
  at_least(c.profile_fit.hypothesis_iterations, 1, "profile_fit.hypothesis_iterations");
  finite_positive(c.covariance.inflation, "covariance.inflation");
  non_negative(c.covariance.min_lateral_std, "covariance.min_lateral_std");
  non_negative(c.covariance.min_axial_std, "covariance.min_axial_std");
  non_negative(c.covariance.min_tilt_std, "covariance.min_tilt_std");
  finite_positive(c.covariance.roll_variance, "covariance.roll_variance");
  non_negative(c.covariance.extrinsic_translation_std, "covariance.extrinsic_translation_std");
  non_negative(c.covariance.extrinsic_rotation_std, "covariance.extrinsic_rotation_std");
  at_least(c.baseline.layers, 1, "baseline.layers");
  finite_positive(c.baseline.square_size, "baseline.square_size");
  if (!(c.baseline.band_max_z > c.baseline.band_min_z))
    fail("estimator config: baseline.band_max_z must be > baseline.band_min_z");
  if (c.baseline.icp_iterations < 1 || c.baseline.icp_runs < 1)
    fail("estimator config: baseline.icp_iterations and baseline.icp_runs must be >= 1");
  finite_positive(c.baseline.model_spacing, "baseline.model_spacing");
  finite_positive(c.baseline.prealign_distance, "baseline.prealign_distance");
}


}  // namespace drill_pipe_pose
