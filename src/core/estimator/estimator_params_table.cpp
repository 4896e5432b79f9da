// The pose estimator's parameter table (estimator_params_table.hpp). One line per parameter:
// key, field, unit, allowed range, one line of documentation. Defaults are the struct's.
// (Long by nature: tables, not logic; one function per section of keys.)

#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

namespace {

using C = EstimatorConfig;
#define P(key, field, unit, range, doc) DPP_PARAM(C, key, field, unit, range, doc)

/// Rows: the method, threads and work zone; the pipe type and the tool-joint model.
ParamTable<C> generalRows() {
  return {
      paramEnum<C>(
          "method", {"ours", "thesis_baseline"},
          "`ours`, or `thesis_baseline` (the thesis's chapter 3.4 steps, for comparison)",
          [](auto& c) -> auto& { return c.method; },
          [](EstimatorMethod m) { return estimatorMethodName(m); },
          [](const std::string& s) { return parseEstimatorMethod(s, "parameter method"); }),
      P("threads", threads, "", atLeast(1),
        "threads per cycle: the two ends, the models' hypotheses and the free/locked refinements "
        "run in parallel (same results as 1)"),
      P("work_zone/min", work_zone.min, "m", anyValue(),
        "world box (min corner); everything outside is ignored"),
      P("work_zone/max", work_zone.max, "m", anyValue(), "world box (max corner)"),

      P("tool_joint/type", pipe_type, "", anyValue(),
        "the pipe catalogue's entry the models start from; tool_joint/* figures that differ from "
        "their defaults override it (\"\": tool_joint/* alone, no classification)"),
      P("pipe_types", pipe_types, "", anyValue(),
        "catalogue entries an end may be classified as ([all]: every one)"),
      P("pipe_catalog", pipe_catalog, "", anyValue(),
        "pipe catalogue file (\"\": the package's config/pipe_catalog.yaml)"),
      P("typing/enabled", typing.enabled, "", anyValue(),
        "measure each end's tool-joint OD and classify its pipe type"),
      P("typing/systematic", typing.systematic, "m", positive(),
        "error of the mean measured radius that averaging does not remove"),
      P("typing/wear", typing.wear, "m", atLeast(0),
        "a radius up to this below a type's is as likely as its own (worn joints; small: the "
        "searched radius reads joints at or over nominal)"),
      P("typing/switch_probability", typing.switch_probability, "", between(0.5, 1),
        "a decision changes an end's type (and model) only this probable"),
      P("typing/min_measurements", typing.min_measurements, "", atLeast(1),
        "...and only after this many measurements on its track"),
      P("tool_joint/tube_od", dims.tube_od, "m", positive(), "pipe body OD (default 5\" NC50)"),
      P("tool_joint/tube_id", dims.tube_id, "m", positive(), "pipe body ID"),
      P("tool_joint/tool_joint_od", dims.tool_joint_od, "m", positive(), "tool-joint OD"),
      P("tool_joint/tool_joint_id", dims.tool_joint_id, "m", positive(), "tool-joint bore"),
      P("tool_joint/elevator_taper_deg", dims.elevator_taper_deg, "deg", atLeast(1),
        "angle between the elevator taper and the axis"),
      P("tool_joint/pin_tong_length", dims.pin_tong_length, "m", positive(),
        "pin tool joint: shoulder to start of the taper"),
      P("tool_joint/box_tong_length", dims.box_tong_length, "m", positive(),
        "box tool joint: end face to start of the taper"),
      P("tool_joint/pin_length", dims.pin_length, "m", positive(), "pin cone: shoulder to nose"),
      P("tool_joint/pin_large_diameter", dims.pin_large_diameter, "m", positive(),
        "pin cone diameter at the shoulder"),
      P("tool_joint/pin_taper", dims.pin_taper, "", atLeast(0),
        "diameter change per length of the pin cone"),
      P("tool_joint/box_counterbore_diameter", dims.box_counterbore_diameter, "m", positive(),
        "box bore at the end face"),
      P("tool_joint/box_thread_depth", dims.box_thread_depth, "m", positive(),
        "depth of the box's threaded cone from the end face"),
      P("tool_joint/threads", dims.threads, "", anyValue(),
        "model the thread ridges on the pin / in the box"),
      P("tool_joint/threads_per_inch", dims.threads_per_inch, "1/in", positive(),
        "thread pitch (with tool_joint/threads)"),
      P("tool_joint/thread_height", dims.thread_height, "m", atLeast(0),
        "radial height of a thread ridge"),
      P("tool_joint/tube_length", dims.tube_length, "m", positive(),
        "tube below the taper that the models include"),
  };
}

/// Rows: cutting out, carving and the instances of a label.
ParamTable<C> segmentationRows() {
  return {
      P("cutout/box_margin_px", cutout.box_margin_px, "px", atLeast(0),
        "a detection box is grown by this on every side (colour pixels)"),
      P("cutout/min_range", cutout.min_range, "m", positive(), "depth below this is ignored"),
      P("cutout/max_range", cutout.max_range, "m", positive(),
        "depth above this is ignored (> cutout/min_range)"),
      P("cutout/min_confidence", cutout.min_confidence, "", atLeast(0),
        "boxes below this detector confidence are ignored"),
      P("cutout/edge_jump", cutout.edge_jump, "m", atLeast(0),
        "drop a pixel whose depth differs from a neighbour's by more (mixed pixels); 0: off"),

      P("carving/min_cameras", carving.min_cameras, "", atLeast(1),
        "a point is kept when inside a same-label box in at least this many cameras"),
      P("carving/vote_fraction", carving.vote_fraction, "", between(0, 1),
        "...and in at least this fraction of the cameras that can judge it"),
      P("carving/margin_px", carving.margin_px, "px", atLeast(0),
        "boxes grown by this when voting (box jitter)"),
      P("carving/occlusion_margin", carving.occlusion_margin, "m", atLeast(0),
        "a camera seeing something nearer than the point by more does not vote; 0: all vote"),
      P("carving/box_reach", carving.box_reach, "m", atLeast(0),
        "a camera votes against a point only with a box holding points this close; 0: always"),
      P("carving/count_boxes", carving.count_boxes, "", anyValue(),
        "also keep a point that the cameras with the most boxes of the label agree on"),

      P("instances/cluster_tolerance", instances.cluster_tolerance, "m", positive(),
        "grid cell edge of the clustering into candidate ends"),
      P("instances/split_at_support", instances.split_at_support, "", anyValue(),
        "split a cluster that a level support (floor, catwalk) joins into its ends"),
      P("instances/handling_point", instances.handling_point, "m", anyValue(),
        "[x, y, z] world: each label's primary end is its end nearest this point ([]: none, the "
        "best-fitting one)"),
      P("instances/primary_by_standoff", instances.primary_by_standoff, "", anyValue(),
        "without a handling_point: the primary pair is the connection being made with the "
        "smallest stand-off, when there is one (else the best-fitting ends)"),
      P("instances/max_instances", instances.max_instances, "", atLeast(1),
        "clusters decided per cycle"),
      P("instances/max_other_ends", instances.max_other_ends, "", atLeast(0),
        "other ends each label follows and publishes besides its own (pipe_end_types); 0: none"),
      P("instances/track_gate", instances.track_gate, "m", positive(),
        "a track follows the cluster with a point this close to its prediction"),
      P("instances/min_cost_margin", instances.min_cost_margin, "", atLeast(0),
        "the best instance's mean cost must be lower than the next's by this fraction"),
      P("instances/min_decisions", instances.min_decisions, "", atLeast(1),
        "decisions an instance needs before it is chosen among several"),
      P("instances/memory_decisions", instances.memory_decisions, "", atLeast(1),
        "decisions averaged per instance"),
      P("instances/radius_difference", instances.radius_difference, "m", atLeast(0),
        "instances whose radii differ by more are two pipe sizes; 0: off"),
      P("instances/memory_s", instances.memory_s, "s", positive(),
        "an instance not decided for this long is forgotten"),
      P("instances/reversal_reach", instances.reversal_reach, "m", atLeast(0),
        "a fit reversed against an instance this far along its axis is that one flipped (0: off)"),
      P("instances/confirm_fits", instances.confirm_fits, "", atLeast(1),
        "fits a new other end needs before it is published (1: from its first)"),
  };
}

/// Rows: the axis fit and the support plane.
ParamTable<C> axisFitRows() {
  return {
      P("axis_fit/min_points", axis_fit.min_points, "", atLeast(10),
        "fewer carved points: the end is invalid"),
      P("axis_fit/max_points", axis_fit.max_points, "", atLeast(20),
        "larger sets are subsampled for the axis fit"),
      P("axis_fit/hypotheses", axis_fit.hypotheses, "", atLeast(0),
        "local-PCA RANSAC hypotheses besides the global PCA"),
      P("axis_fit/direction_samples", axis_fit.direction_samples, "", atLeast(0),
        "axis directions sampled over the hemisphere; 0: off"),
      P("axis_fit/neighbourhood", axis_fit.neighbourhood, "m", positive(),
        "radius of a hypothesis's local PCA"),
      P("axis_fit/inlier_threshold", axis_fit.inlier_threshold, "m", positive(),
        "|distance to axis - radius| of a cylinder inlier"),
      P("axis_fit/iterations", axis_fit.iterations, "", atLeast(1),
        "Gauss-Newton iterations per hypothesis"),
      P("axis_fit/seed", axis_fit.seed, "", between(0, 4294967295.0), "random sampling seed"),
      P("axis_fit/plane_iterations", axis_fit.plane_iterations, "", atLeast(0),
        "RANSAC iterations of the support-plane removal; 0: off"),
      P("axis_fit/plane_threshold", axis_fit.plane_threshold, "m", positive(),
        "support-plane inlier distance"),
      P("axis_fit/plane_min_fraction", axis_fit.plane_min_fraction, "", atLeast(0),
        "a support plane holds at least this fraction of the points"),
      P("axis_fit/plane_min_extent", axis_fit.plane_min_extent, "m", atLeast(0),
        "...and spreads at least this much along its narrower direction"),
  };
}

/// Rows: the profile fit.
ParamTable<C> profileFitRows() {
  return {
      P("profile_fit/search_step", profile_fit.search_step, "m", positive(),
        "step of the 1-DoF axial search"),
      P("profile_fit/silhouette_points", profile_fit.silhouette_points, "", anyValue(),
        "pixels whose ray misses the model beside the joint's sides count in the final fit"),
      P("profile_fit/silhouette_min_inlier_fraction", profile_fit.silhouette_min_inlier_fraction,
        "", between(0, 1), "...while the fit explains at least this fraction of its points"),
      P("profile_fit/incidence_noise", profile_fit.incidence_noise, "mm", atLeast(0),
        "depth sigma grows toward grazing incidence by this x z^1.5 (theta/(pi/2-theta))^2; "
        "0: off"),
      P("profile_fit/reflectivity", profile_fit.reflectivity, "", between(0, 1),
        "surface reflectivity the final fit predicts amplitudes with (weak-return bias and noise "
        "of the Kinect v2); 0: off"),
      P("profile_fit/bias_reference", profile_fit.bias_reference, "1/m^2", atLeast(0),
        "amplitude whose weak-return bias the depth calibration removed; 0: none"),
      P("profile_fit/truncation", profile_fit.truncation, "m", positive(),
        "robust cost: residuals beyond this cost as much as this"),
      P("profile_fit/wear_margin", profile_fit.wear_margin, "m", atLeast(0),
        "only the tong within (tong length - this) of the shoulder is trusted"),
      P("profile_fit/support_clearance", profile_fit.support_clearance, "m", atLeast(0),
        "points less than this above a level support are left out of the final fit; 0: off"),
      P("profile_fit/iterations", profile_fit.iterations, "", atLeast(1),
        "IRLS Gauss-Newton iterations of the final refinement"),
      P("profile_fit/hypothesis_iterations", profile_fit.hypothesis_iterations, "", atLeast(1),
        "iterations of each hypothesis before the decision"),
      P("profile_fit/huber", profile_fit.huber, "sigma", positive(),
        "Huber threshold in units of the point's noise sigma"),
      P("profile_fit/label_margin", profile_fit.label_margin, "", atLeast(0),
        "a label is replaced when the other model's cost is lower by this fraction"),
      P("profile_fit/search_points", profile_fit.search_points, "", atLeast(20),
        "points used in the 1-DoF axial search"),
      P("profile_fit/coarse_points", profile_fit.coarse_points, "", atLeast(20),
        "points of the coarse stages (hypotheses, fine scan, first iterations)"),
      P("profile_fit/polish_iterations", profile_fit.polish_iterations, "", atLeast(1),
        "last refinement iterations, on every point"),
      P("profile_fit/max_points", profile_fit.max_points, "", atLeast(1),
        "larger end clouds are subsampled (>= axis_fit/min_points)"),
      P("profile_fit/long_tong_search", profile_fit.long_tong_search, "", anyValue(),
        "search the axial position with a 0.3 m longer tong"),
      P("profile_fit/max_rms", profile_fit.max_rms, "m", positive(),
        "a fit with a larger inlier RMS residual is invalid"),
      P("profile_fit/min_inlier_fraction", profile_fit.min_inlier_fraction, "", atLeast(0),
        "a fit explaining fewer of its points is invalid"),
      P("profile_fit/max_axial_std", profile_fit.max_axial_std, "m", positive(),
        "a fit with a larger std along the axis is invalid"),
      P("profile_fit/max_tilt_std", profile_fit.max_tilt_std, "rad", positive(),
        "a fit with a larger tilt std is invalid"),
  };
}

/// Rows: the free-space check.
ParamTable<C> freeSpaceRows() {
  return {
      P("free_space/enabled", free_space.enabled, "", anyValue(),
        "check hypotheses against the depth images' free space"),
      P("free_space/decide_hypotheses", free_space.decide_hypotheses, "", anyValue(),
        "seen-through pixels enter the model/direction decision"),
      P("free_space/axial_scan", free_space.axial_scan, "", anyValue(),
        "scan the position along the axis with the free-space score"),
      P("free_space/pixel_weight", free_space.pixel_weight, "points", atLeast(0),
        "a seen-through depth pixel costs this many unexplained points"),
      P("free_space/margin", free_space.margin, "m", positive(),
        "depth beyond the model surface that counts as seen-through (at least)"),
      P("free_space/sample_spacing", free_space.sample_spacing, "m", atLeast(1e-4),
        "spacing of the model surface samples"),
      P("free_space/tube_length", free_space.tube_length, "m", atLeast(0),
        "tube below the taper that the checked model includes"),
      P("free_space/min_cos_incidence", free_space.min_cos_incidence, "", between(0, 1, true),
        "samples seen at a smaller cosine of incidence are not judged"),
      P("free_space/axial_range", free_space.axial_range, "m", atLeast(0),
        "+- range of the scan along the axis"),
      P("free_space/decision_step", free_space.decision_step, "m", atLeast(1e-4),
        "step of every hypothesis's scan"),
      P("free_space/axial_step", free_space.axial_step, "m", atLeast(1e-4),
        "step of the winner's fine scan"),
      P("free_space/min_direction_margin", free_space.min_direction_margin, "points", atLeast(0),
        "invalid when the flipped direction scores less than this much worse"),
      P("free_space/min_axial_contrast", free_space.min_axial_contrast, "points", anyValue(),
        "an axial position the score contradicts by more is invalid"),
      P("edges/enabled", edges.enabled, "", anyValue(),
        "move the end along its axis to its depth pixels' likelihood, edge pixels read as dropped or mixed"),
      P("edges/scan_range", edges.scan_range, "m", between(0, 0.1),
        "+- scan along the axis from the registration's position"),
      P("edges/step_invalid", edges.step_invalid, "", between(0.01, 0.99),
        "prior: P(no depth) of a pixel beside a depth step of the model"),
      P("edges/surface_invalid", edges.surface_invalid, "", between(0.001, 0.9),
        "prior: P(no depth) of a pixel on the model away from its steps"),
      P("edges/wrong", edges.wrong, "", between(1e-4, 0.5),
        "prior: P(a pixel away from steps reads through the model, or a surface off it)"),
      P("edges/region_below", edges.region_below, "m", between(0.01, 0.5),
        "the judged region's extent below the end's top, along the axis"),
      P("edges/region_above", edges.region_above, "m", between(0.0, 0.5),
        "the judged region's extent beyond the end's top, along the axis"),
      P("edges/prior_pixels", edges.prior_pixels, "pixels", atLeast(1),
        "weight of the edges/* probabilities against the pixels' own counts"),
      P("edges/min_step_missing", edges.min_step_missing, "", between(0, 1),
        "the scan runs where at least this share of the pixels beside steps is missing"),
      P("edges/camera_min_step_missing", edges.camera_min_step_missing, "", between(0, 1),
        "a camera whose step pixels are missing less than this share is left out of the scan"),
      P("edges/min_cameras", edges.min_cameras, "", between(1, 64),
        "cameras the scan needs where some are left out"),
      P("edges/max_motion", edges.max_motion, "m", between(0, 1),
        "the scan is skipped where the end moves more than this within the cycle's frames"),
  };
}

/// Rows: noise, covariance and the temporal filter.
ParamTable<C> uncertaintyRows() {
  return {
      P("noise/scale", noise.scale, "", positive(),
        "depth sigma = scale x (1.5 - 0.5 z + 0.3 z^2) mm"),
      P("noise/min_sigma", noise.min_sigma, "m", positive(), "smallest depth sigma"),
      P("noise/amplitude_scale", noise.amplitude_scale, "DN m^2", positive(),
        "amplitude image value per unit of returned amplitude (reflectivity cos / range^2); "
        "40260: Kinect v2 through kinect2_bridge"),
      P("noise/amplitude_model", noise.amplitude_model, "", anyValue(),
        "take each pixel's weak-return bias out of its depth, from the frame's amplitude "
        "(docs/measurement_model.md); false: amplitude ignored"),

      P("covariance/inflation", covariance.inflation, "", positive(),
        "factor on Hessian^-1 x reduced chi^2 (correlated noise)"),
      P("covariance/min_lateral_std", covariance.min_lateral_std, "m", atLeast(0),
        "std added across the axis"),
      P("covariance/min_axial_std", covariance.min_axial_std, "m", atLeast(0),
        "std added along the axis"),
      P("covariance/min_tilt_std", covariance.min_tilt_std, "rad", atLeast(0),
        "std added about the end's x and y"),
      P("covariance/roll_variance", covariance.roll_variance, "rad^2", positive(),
        "variance about the axis (unobservable)"),
      P("covariance/extrinsic_translation_std", covariance.extrinsic_translation_std, "m",
        atLeast(0), "rig calibration uncertainty per camera (1 sigma), added; 0: exact"),
      P("covariance/extrinsic_rotation_std", covariance.extrinsic_rotation_std, "rad",
        atLeast(0), "rig calibration rotation uncertainty per camera (1 sigma); 0: exact"),

      P("temporal/enabled", temporal.enabled, "", anyValue(),
        "temporal filter of each end's pose"),
      P("temporal/acceleration_density", temporal.acceleration_density, "m^2/s^3", positive(),
        "larger follows sudden moves faster, smaller smooths more"),
      P("temporal/tilt_rate_density", temporal.tilt_rate_density, "rad^2/s", positive(),
        "random-walk density of the axis direction"),
      P("temporal/max_speed", temporal.max_speed, "m/s", positive(),
        "prior velocity std at a (re)start"),
      P("temporal/gate_sigma", temporal.gate_sigma, "sigma", positive(),
        "a measurement further from the prediction is held"),
      P("temporal/confirmations", temporal.confirmations, "", atLeast(0),
        "measurements that must agree with a held one before a restart; 0: at once"),
      P("temporal/confirm_start", temporal.confirm_start, "", anyValue(),
        "a new track's first pose is held likewise until the next agrees"),
      P("temporal/max_gap", temporal.max_gap, "s", positive(),
        "a longer gap between measurements restarts the filter"),
  };
}

/// Rows: drift watch and tracking.
ParamTable<C> trackingRows() {
  return {
      P("drift/enabled", drift.enabled, "", anyValue(),
        "measure each camera's disagreement with the fused fit (drift watch)"),
      P("drift/time_constant", drift.time_constant, "s", positive(),
        "capture-time constant of each camera's running estimate"),
      P("drift/max_ray_shift", drift.max_ray_shift, "m", positive(),
        "a camera whose running shift along its view ray is larger is flagged"),
      P("drift/max_rotation", drift.max_rotation, "deg", positive(),
        "...or whose running rotation (lateral offset / range) is larger"),
      P("drift/release_fraction", drift.release_fraction, "", between(0, 1),
        "a flag is cleared when both figures fall below this fraction of their limits"),
      P("drift/learn_time", drift.learn_time, "s", atLeast(0),
        "each camera's own disagreement on each set of ends it sees is learned over its first "
        "seconds on that set as its baseline there"),
      P("drift/baseline_time_constant", drift.baseline_time_constant, "s", atLeast(0),
        "then the baseline follows the camera with this time constant while unflagged; 0: frozen"),
      P("drift/absolute_factor", drift.absolute_factor, "", atLeast(1),
        "a disagreement this many times the limits is flagged without a baseline"),
      P("drift/gate", drift.gate, "m", positive(),
        "a camera's points further from the fitted surface are not used"),
      P("drift/min_points", drift.min_points, "", atLeast(3),
        "points a camera needs on an end to be measured there"),
      P("drift/leave_out", drift.leave_out, "", anyValue(),
        "flagged cameras' points leave the fit until they agree again"),
      P("drift/min_cameras", drift.min_cameras, "", atLeast(1),
        "...while at least this many cameras not left out remain"),

      P("tracking/enabled", tracking.enabled, "", anyValue(),
        "start each cycle from the end's last pose"),
      P("tracking/redecide_every", tracking.redecide_every, "cycles", atLeast(1),
        "cycles between full decisions of a continuing track"),
      P("tracking/max_gap", tracking.max_gap, "s", positive(),
        "a longer gap since the track's last pose ends it"),
      P("tracking/max_angle", tracking.max_angle, "rad", positive(),
        "a refined axis further from the track's is decided afresh"),
      P("tracking/max_offset", tracking.max_offset, "m", positive(),
        "a refined origin further from the prediction is decided afresh"),
      P("tracking/max_prediction", tracking.max_prediction, "m", positive(),
        "largest move of the prediction"),
  };
}

/// Rows: the thesis baseline.
ParamTable<C> baselineRows() {
  return {
      P("baseline/layers", baseline.layers, "cycles", atLeast(1),
        "thesis_baseline: concatenated clouds"),
      P("baseline/square_size", baseline.square_size, "m", positive(),
        "thesis_baseline: side of the square kept around the centroid"),
      P("baseline/band_min_z", baseline.band_min_z, "m", anyValue(),
        "thesis_baseline: world height band used for the centroid (min)"),
      P("baseline/band_max_z", baseline.band_max_z, "m", anyValue(),
        "thesis_baseline: height band (max, > baseline/band_min_z)"),
      P("baseline/icp_iterations", baseline.icp_iterations, "", atLeast(1),
        "thesis_baseline: ICP maximum iterations"),
      P("baseline/icp_runs", baseline.icp_runs, "", atLeast(1),
        "thesis_baseline: ICP runs per cycle"),
      P("baseline/model_spacing", baseline.model_spacing, "m", positive(),
        "thesis_baseline: model cloud point spacing"),
      P("baseline/prealign_distance", baseline.prealign_distance, "m", positive(),
        "thesis_baseline: re-pre-align when the model is further than this"),
      P("baseline/min_points", baseline.min_points, "", atLeast(0),
        "thesis_baseline: fewer segmented points: invalid"),
      P("baseline/position_std", baseline.position_std, "m", atLeast(0),
        "thesis_baseline: reported std per axis"),
      P("baseline/tilt_std", baseline.tilt_std, "rad", atLeast(0),
        "thesis_baseline: reported std about x and y"),
  };
}

/// Every row, in the order docs/parameters.md lists them.
ParamTable<EstimatorConfig> makeEstimatorTable() {
  ParamTable<C> t;
  for (ParamTable<C> (*rows)() : {generalRows, segmentationRows, axisFitRows, profileFitRows,
                                  freeSpaceRows, uncertaintyRows, trackingRows, baselineRows}) {
    const ParamTable<C> r = rows();
    t.insert(t.end(), r.begin(), r.end());
  }
  return t;
}
#undef P

using N = EstimatorNodeConfig;
#define P(key, field, unit, range, doc) DPP_PARAM(N, key, field, unit, range, doc)

ParamTable<EstimatorNodeConfig> makeNodeTable() {
  ParamTable<N> t{
      P("cameras", cameras, "", anyValue(),
        "(required) sensor node names, e.g. [cam1, cam2]; one camera works too"),
      P("world_frame", world_frame, "", anyValue(), "frame of the poses"),
      P("box_end_frame", end_frames[0], "", anyValue(), "TF child frame of the box end"),
      P("pin_end_frame", end_frames[1], "", anyValue(), "TF child frame of the pin end"),
      P("max_pose_age", max_pose_age, "s", atLeast(0),
        "an end not seen for longer is published invalid, never silently repeated"),
      P("tf_timeout", tf_timeout, "s", atLeast(0), "wait per TF lookup (0: what is buffered)"),
      P("rig", rig, "", anyValue(),
        "rig file whose depth_offset / depth_scale correct each camera's depth "
        "(docs/conventions.md \"Rig file\"); empty: none"),
      P("sync/window", sync.window, "s", atLeast(1e-4), "capture-stamp span of one cycle"),
      P("sync/max_wait", sync.max_wait, "s", atLeast(0),
        "how long a cycle waits for a late camera"),
      P("sync/camera_timeout", sync.camera_timeout, "s", atLeast(1e-3),
        "silence after which a camera leaves the fusion (it rejoins with its next frame; one never heard leaves after sync/max_wait)"),
      P("sync/buffer_size", sync.buffer_size, "frames", atLeast(1), "frames kept per camera"),
      P("limits/max_image_pixels", limits.max_image_pixels, "pixels", atLeast(1),
        "a SensorFrame whose depth image or CameraInfo declares more pixels is dropped"),
      P("limits/max_boxes", limits.max_boxes, "boxes", atLeast(0),
        "a SensorFrame with more boxes is dropped (a broken detector)"),
      P("debug/frustum_length", debug_frustum_length, "m", positive(),
        "drawn length of each camera's colour frustum in debug/models"),
  };
  const auto est =
      nestParams<N>(estimatorParamTable(), "", [](auto& n) -> auto& { return n.estimator; });
  t.insert(t.end(), est.begin(), est.end());
  return t;
}
#undef P

}  // namespace

const ParamTable<EstimatorConfig>& estimatorParamTable() {
  static const ParamTable<EstimatorConfig> table = makeEstimatorTable();
  return table;
}

const ParamTable<EstimatorNodeConfig>& estimatorNodeParamTable() {
  static const ParamTable<EstimatorNodeConfig> table = makeNodeTable();
  return table;
}

void applyParam(EstimatorConfig* config, const std::string& key, const std::string& value) {
  applyParamString(estimatorParamTable(), config, key, value, "");
}

void loadEstimatorYaml(EstimatorConfig* config, const std::string& path) {
  // The node's own keys are type- and range-checked too (into a scratch node config).
  EstimatorNodeConfig node;
  node.estimator = *config;
  applyParamYaml(estimatorNodeParamTable(), &node, path);
  try {
    validateConfig(node.estimator);
  } catch (const InputError& e) {
    fail(path, ": ", e.what());
  }
  *config = node.estimator;
}

void loadEstimatorNodeYaml(EstimatorNodeConfig* config, const std::string& path) {
  EstimatorNodeConfig c = *config;
  applyParamYaml(estimatorNodeParamTable(), &c, path);
  try {
    validateEstimatorNodeConfig(c);
  } catch (const InputError& e) {
    fail(path, ": ", e.what());
  }
  *config = c;
}

void validateEstimatorNodeConfig(const EstimatorNodeConfig& c) {
  if (c.cameras.empty())
    fail("parameter cameras is missing or empty: list the sensor nodes to fuse, e.g. [cam1, cam2]");
  checkParamRanges(estimatorNodeParamTable(), c, "pose_estimator config");
  validateConfig(c.estimator);
}

std::string estimatorParamsMarkdown() {
  return paramTableMarkdown(estimatorNodeParamTable());
}

}  // namespace drill_pipe_pose
