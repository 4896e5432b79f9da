#include "drill_pipe_pose/ros/estimator_params.hpp"

#include <sstream>

#include "drill_pipe_pose/ros/params.hpp"

namespace drill_pipe_pose {

EstimatorConfig loadEstimatorConfig(const ros::NodeHandle& pnh) {
  EstimatorConfig c;
  std::string method = estimatorMethodName(c.method);
  readParam(pnh, "method", method);
  c.method = parseEstimatorMethod(method, "parameter " + pnh.resolveName("method"));
  c.threads = 2;  // the node's default: a cycle's independent fits on two cores
  readNumber(pnh, "threads", c.threads, 1.0);
  readVector3(pnh, "work_zone/min", c.work_zone.min);
  readVector3(pnh, "work_zone/max", c.work_zone.max);

  ToolJointDimensions& d = c.dims;
  readNumber(pnh, "tool_joint/tube_od", d.tube_od, 0.0);
  readNumber(pnh, "tool_joint/tube_id", d.tube_id, 0.0);
  readNumber(pnh, "tool_joint/tool_joint_od", d.tool_joint_od, 0.0);
  readNumber(pnh, "tool_joint/tool_joint_id", d.tool_joint_id, 0.0);
  readNumber(pnh, "tool_joint/elevator_taper_deg", d.elevator_taper_deg, 0.0);
  readNumber(pnh, "tool_joint/pin_tong_length", d.pin_tong_length, 0.0);
  readNumber(pnh, "tool_joint/box_tong_length", d.box_tong_length, 0.0);
  readNumber(pnh, "tool_joint/pin_length", d.pin_length, 0.0);
  readNumber(pnh, "tool_joint/pin_large_diameter", d.pin_large_diameter, 0.0);
  readNumber(pnh, "tool_joint/pin_taper", d.pin_taper, 0.0);
  readNumber(pnh, "tool_joint/box_counterbore_diameter", d.box_counterbore_diameter, 0.0);
  readNumber(pnh, "tool_joint/box_thread_depth", d.box_thread_depth, 0.0);
  readNumber(pnh, "tool_joint/tube_length", d.tube_length, 0.0);

  readNumber(pnh, "cutout/box_margin_px", c.cutout.box_margin_px, 0.0);
  readNumber(pnh, "cutout/min_range", c.cutout.min_range, 0.0);
  readNumber(pnh, "cutout/max_range", c.cutout.max_range, 0.0);
  readNumber(pnh, "cutout/min_confidence", c.cutout.min_confidence, 0.0);
  readNumber(pnh, "cutout/edge_jump", c.cutout.edge_jump, 0.0);

  readNumber(pnh, "carving/min_cameras", c.carving.min_cameras, 1.0);
  readNumber(pnh, "carving/vote_fraction", c.carving.vote_fraction, 0.0);
  readNumber(pnh, "carving/margin_px", c.carving.margin_px, 0.0);
  readNumber(pnh, "carving/occlusion_margin", c.carving.occlusion_margin, 0.0);
  readNumber(pnh, "carving/box_reach", c.carving.box_reach, 0.0);
  readNumber(pnh, "instances/cluster_tolerance", c.instances.cluster_tolerance, 0.0);
  readNumber(pnh, "instances/max_instances", c.instances.max_instances, 1.0);
  readNumber(pnh, "instances/track_gate", c.instances.track_gate, 0.0);
  readNumber(pnh, "instances/min_cost_margin", c.instances.min_cost_margin, 0.0);
  readNumber(pnh, "instances/min_decisions", c.instances.min_decisions, 1.0);
  readNumber(pnh, "instances/memory_decisions", c.instances.memory_decisions, 1.0);
  readNumber(pnh, "instances/memory_s", c.instances.memory_s, 0.0);
  readNumber(pnh, "instances/radius_difference", c.instances.radius_difference, 0.0);

  readNumber(pnh, "axis_fit/min_points", c.axis_fit.min_points, 3.0);
  readNumber(pnh, "axis_fit/max_points", c.axis_fit.max_points, 3.0);
  readNumber(pnh, "axis_fit/hypotheses", c.axis_fit.hypotheses, 0.0);
  readNumber(pnh, "axis_fit/neighbourhood", c.axis_fit.neighbourhood, 0.0);
  readNumber(pnh, "axis_fit/inlier_threshold", c.axis_fit.inlier_threshold, 0.0);
  readNumber(pnh, "axis_fit/iterations", c.axis_fit.iterations, 1.0);
  readNumber(pnh, "axis_fit/seed", c.axis_fit.seed, 0.0);
  readNumber(pnh, "axis_fit/direction_samples", c.axis_fit.direction_samples, 0.0);
  readNumber(pnh, "axis_fit/plane_iterations", c.axis_fit.plane_iterations, 0.0);
  readNumber(pnh, "axis_fit/plane_threshold", c.axis_fit.plane_threshold, 0.0);
  readNumber(pnh, "axis_fit/plane_min_fraction", c.axis_fit.plane_min_fraction, 0.0);
  readNumber(pnh, "axis_fit/plane_min_extent", c.axis_fit.plane_min_extent, 0.0);

  readNumber(pnh, "profile_fit/search_step", c.profile_fit.search_step, 0.0);
  readNumber(pnh, "profile_fit/truncation", c.profile_fit.truncation, 0.0);
  readNumber(pnh, "profile_fit/wear_margin", c.profile_fit.wear_margin, 0.0);
  readNumber(pnh, "profile_fit/support_clearance", c.profile_fit.support_clearance, 0.0);
  readNumber(pnh, "profile_fit/iterations", c.profile_fit.iterations, 1.0);
  readNumber(pnh, "profile_fit/huber", c.profile_fit.huber, 0.0);
  readNumber(pnh, "profile_fit/label_margin", c.profile_fit.label_margin, 0.0);
  readNumber(pnh, "profile_fit/search_points", c.profile_fit.search_points, 1.0);
  readNumber(pnh, "profile_fit/coarse_points", c.profile_fit.coarse_points, 1.0);
  readNumber(pnh, "profile_fit/polish_iterations", c.profile_fit.polish_iterations, 1.0);
  readNumber(pnh, "profile_fit/hypothesis_iterations", c.profile_fit.hypothesis_iterations, 1.0);
  readNumber(pnh, "profile_fit/max_rms", c.profile_fit.max_rms, 0.0);
  readNumber(pnh, "profile_fit/min_inlier_fraction", c.profile_fit.min_inlier_fraction, 0.0);
  readParam(pnh, "profile_fit/silhouette_points", c.profile_fit.silhouette_points);
  readNumber(pnh, "profile_fit/incidence_noise", c.profile_fit.incidence_noise, 0.0);
  readNumber(pnh, "profile_fit/silhouette_min_inlier_fraction",
             c.profile_fit.silhouette_min_inlier_fraction, 0.0);
  readNumber(pnh, "profile_fit/max_axial_std", c.profile_fit.max_axial_std, 0.0);
  readNumber(pnh, "profile_fit/max_tilt_std", c.profile_fit.max_tilt_std, 0.0);

  readNumber(pnh, "profile_fit/max_points", c.profile_fit.max_points, 1.0);
  readParam(pnh, "profile_fit/long_tong_search", c.profile_fit.long_tong_search);

  readParam(pnh, "free_space/enabled", c.free_space.enabled);
  readParam(pnh, "free_space/decide_hypotheses", c.free_space.decide_hypotheses);
  readParam(pnh, "free_space/axial_scan", c.free_space.axial_scan);
  readNumber(pnh, "free_space/pixel_weight", c.free_space.pixel_weight, 0.0);
  readNumber(pnh, "free_space/margin", c.free_space.margin, 0.0);
  readNumber(pnh, "free_space/sample_spacing", c.free_space.sample_spacing, 1e-4);
  readNumber(pnh, "free_space/tube_length", c.free_space.tube_length, 0.0);
  readNumber(pnh, "free_space/min_cos_incidence", c.free_space.min_cos_incidence, 0.0);
  readNumber(pnh, "free_space/axial_range", c.free_space.axial_range, 0.0);
  readNumber(pnh, "free_space/decision_step", c.free_space.decision_step, 1e-4);
  readNumber(pnh, "free_space/axial_step", c.free_space.axial_step, 1e-4);
  readNumber(pnh, "free_space/min_direction_margin", c.free_space.min_direction_margin, 0.0);
  readNumber(pnh, "free_space/min_axial_contrast", c.free_space.min_axial_contrast, 0.0);

  readNumber(pnh, "noise/scale", c.noise.scale, 0.0);
  readNumber(pnh, "noise/min_sigma", c.noise.min_sigma, 0.0);

  readParam(pnh, "temporal/enabled", c.temporal.enabled);
  readNumber(pnh, "temporal/acceleration_density", c.temporal.acceleration_density, 0.0);
  readNumber(pnh, "temporal/tilt_rate_density", c.temporal.tilt_rate_density, 0.0);
  readNumber(pnh, "temporal/max_speed", c.temporal.max_speed, 0.0);
  readNumber(pnh, "temporal/gate_sigma", c.temporal.gate_sigma, 0.0);
  readNumber(pnh, "temporal/confirmations", c.temporal.confirmations, 0.0);
  readNumber(pnh, "temporal/max_gap", c.temporal.max_gap, 0.0);
  readParam(pnh, "tracking/enabled", c.tracking.enabled);
  readNumber(pnh, "tracking/redecide_every", c.tracking.redecide_every, 1.0);
  readNumber(pnh, "tracking/max_gap", c.tracking.max_gap, 0.0);
  readNumber(pnh, "tracking/max_angle", c.tracking.max_angle, 0.0);
  readNumber(pnh, "tracking/max_offset", c.tracking.max_offset, 0.0);
  readNumber(pnh, "tracking/max_prediction", c.tracking.max_prediction, 0.0);

  readNumber(pnh, "covariance/inflation", c.covariance.inflation, 0.0);
  readNumber(pnh, "covariance/min_lateral_std", c.covariance.min_lateral_std, 0.0);
  readNumber(pnh, "covariance/min_axial_std", c.covariance.min_axial_std, 0.0);
  readNumber(pnh, "covariance/min_tilt_std", c.covariance.min_tilt_std, 0.0);
  readNumber(pnh, "covariance/roll_variance", c.covariance.roll_variance, 0.0);
  readNumber(pnh, "covariance/extrinsic_translation_std", c.covariance.extrinsic_translation_std,
             0.0);
  readNumber(pnh, "covariance/extrinsic_rotation_std", c.covariance.extrinsic_rotation_std, 0.0);

  readNumber(pnh, "baseline/layers", c.baseline.layers, 1.0);
  readNumber(pnh, "baseline/square_size", c.baseline.square_size, 0.0);
  readNumber(pnh, "baseline/band_min_z", c.baseline.band_min_z, -1e9);
  readNumber(pnh, "baseline/band_max_z", c.baseline.band_max_z, -1e9);
  readNumber(pnh, "baseline/icp_iterations", c.baseline.icp_iterations, 1.0);
  readNumber(pnh, "baseline/icp_runs", c.baseline.icp_runs, 1.0);
  readNumber(pnh, "baseline/model_spacing", c.baseline.model_spacing, 0.0);
  validateConfig(c);
  return c;
}

std::string describeEstimatorConfig(const EstimatorConfig& c) {
  std::ostringstream s;
  s << "method " << estimatorMethodName(c.method) << "; work zone [" << c.work_zone.min.transpose()
    << "] .. [" << c.work_zone.max.transpose() << "] m; tool joint OD " << c.dims.tool_joint_od
    << " m, tube OD " << c.dims.tube_od << " m; cut-out margin " << c.cutout.box_margin_px
    << " px, range " << c.cutout.min_range << ".." << c.cutout.max_range << " m, min confidence "
    << c.cutout.min_confidence << "; carving min cameras " << c.carving.min_cameras
    << ", vote fraction " << c.carving.vote_fraction << ", box reach " << c.carving.box_reach
    << " m";
  return s.str();
}

}  // namespace drill_pipe_pose
