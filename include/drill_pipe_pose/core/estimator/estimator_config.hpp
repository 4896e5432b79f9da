#pragma once
// Configuration of the ROS-free pose estimator. Nested structs with defaults; units in
// the comments. These initialisers are the one place the defaults live: they are the
// pose_estimator node's defaults too. Every field has one row in the parameter table
// (estimator_params_table.hpp) giving its key, unit, range and doc, from which the node's loader,
// validateConfig, the tools' --config / --param and the parameter reference (docs/parameters.md) follow.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/estimator/pipe_type.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

/// Which pipeline PoseEstimator::process runs.
enum class EstimatorMethod {
  kOurs,            ///< carving + axis fit + profile registration (the project's method)
  kThesisBaseline,  ///< the thesis's chapter 3.4 steps (comparison baseline, faithful not improved)
};

/// "ours" | "thesis_baseline" -> method; anything else throws InputError naming `source`.
EstimatorMethod parseEstimatorMethod(const std::string& name, const std::string& source);
/// "ours" | "thesis_baseline".
const char* estimatorMethodName(EstimatorMethod m);

struct EstimatorConfig {
  EstimatorMethod method = EstimatorMethod::kOurs;
  /// Threads of a cycle: 1 runs it on the calling thread; 2 or more fit the two labels in
  /// parallel, and within a full decision the two models' hypotheses and, in the refinement, the
  /// free and locked fits. The results are the same either way. 2: the node's default (a cycle's
  /// independent fits on two cores); set 1 for single-threaded timing.
  int threads = 2;

  /// Nominal tool-joint geometry the models are built from [m, deg]: the pipe type's
  /// (pipe_type) once resolved (resolvePipeTypes, pipe_catalog.hpp).
  ToolJointDimensions dims;
  /// The catalogue entry (config/pipe_catalog.yaml) the models start from; the tool_joint/*
  /// figures that differ from their defaults override its own. "": tool_joint/* alone, and no
  /// classification. The defaults of tool_joint/* are this entry's figures (a test holds them
  /// equal).
  std::string pipe_type = "5in_NC50_6.625od";
  /// The catalogue entries an end may be classified as ("all": every one).
  std::vector<std::string> pipe_types = {"all"};
  /// The pipe catalogue file; "": the package's config/pipe_catalog.yaml.
  std::string pipe_catalog;
  /// The pipe types resolved from the catalogue (not a parameter: resolvePipeTypes fills it;
  /// empty: the one type of dims, named pipe_type).
  std::vector<PipeCandidate> candidates;
  /// Classifying each end's type among the candidates (pipe_type.hpp).
  TypingConfig typing;

  /// Axis-aligned box in the world frame; points outside are dropped right after the cut-out.
  struct WorkZone {
    Eigen::Vector3d min = Eigen::Vector3d::Constant(-1e3);  ///< [m] world
    Eigen::Vector3d max = Eigen::Vector3d::Constant(1e3);   ///< [m] world
  } work_zone;

  /// Per-camera cut-out of the depth pixels that register into a detection box.
  struct CutOut {
    double box_margin_px = 3.0;   ///< [colour px] a box is grown by this on every side
    double min_range = 0.3;       ///< [m] depth (optical z) below this is ignored
    double max_range = 12.0;      ///< [m] depth above this is ignored
    float min_confidence = 0.0f;  ///< boxes below this detector confidence are ignored
    /// [m] a pixel whose depth differs from a 4-neighbour's by more than max(edge_jump,
    /// 4 sigma) is dropped (mixed / flying pixels, grazing silhouettes); 0 = off.
    double edge_jump = 0.0;
  } cutout;

  /// Visual-hull carving across the cameras' boxes of the same label.
  struct Carving {
    /// A point is kept when it lies inside a same-label box in at least this many cameras
    /// (itself included)... unless fewer cameras than this can judge it (then it is kept).
    int min_cameras = 2;
    /// ...and in at least this fraction of the cameras that can judge it (that have a box of the
    /// label within box_reach and see the point inside their colour image, unoccluded).
    double vote_fraction = 0.75;
    double margin_px = 8.0;  ///< [colour px] boxes grown by this when voting (box jitter)
    /// [m] A camera whose depth at the point's pixel is nearer than the point by more than this
    /// sees something in front of it (a barrel, a person): it cannot see the point and does not
    /// vote (in cluttered it would veto the box end it cannot see). More than the tool joint's
    /// diameter, so that the joint's near side does not hide the floor at its base (0.05 kept
    /// that floor and tilted the box end's axis). Only the depth a cropping sensor node sends is
    /// read (the bounding rectangle of the boxes' frusta, cropDepthToBoxes), so that full and
    /// cropped depth give the same poses. 0 = every camera with the point in its image votes.
    double occlusion_margin = 0.25;
    /// [m] A camera votes against a point (one outside all its boxes of the label) only when
    /// one of those boxes holds cut-out points within this distance of it: that detection, near
    /// the point, leaves it out (clutter beside the joint). A box farther away (another pipe's
    /// end, a false detection) says nothing about the point, since the detector may have missed
    /// the joint in this camera: the camera does not vote, as a camera with no box of the label
    /// does not. Clutter lies within 0.5 m of the pipe; chosen on the cluttered scene, where a
    /// camera whose only pin-end box was on the other pipe's far end vetoed the pin end it had
    /// missed (docs/results.md has the figures with and without). 0 = every camera with a box
    /// of the label votes.
    double box_reach = 0.5;
    /// A camera that boxed fewer ends of the label than at least min_cameras cameras did (boxes
    /// that hold each other's centre count once) may have missed the end a point lies on (a
    /// second pipe's end beside the first): a point is also kept when the cameras that boxed
    /// that many agree on it (min_cameras, vote_fraction), the others left out. Within
    /// box_reach of the end they did box, such cameras carved the second of two identical
    /// pipes' ends 0.4 m apart away whenever two of them missed it. Chosen on catwalk_twin seeds
    /// 93, 190 and 191 and cluttered 130-131; held out on catwalk_twin 192-196 (docs/results.md,
    /// "Pipe types", several pipes at once). false = every camera votes as box_reach says.
    bool count_boxes = true;
  } carving;

  /// Instances: the carved points of a label split into clusters (connected grid cells); each
  /// cluster of at least axis_fit.min_points, measured by at least carving.min_cameras cameras
  /// (fewer when fewer have a box of the label), is one candidate end (another pipe's end, a
  /// detection on clutter). A continuing track follows the cluster nearest its prediction. When
  /// there is no track, and at the track's periodic decisions, the `max_instances` largest are
  /// decided; each keeps a memory of its decisions' costs (mean over the last
  /// `memory_decisions`), and the instance with the lowest mean cost is the end (chooseInstance
  /// in instances.hpp has the rules).
  struct Instances {
    /// [m] grid cell edge (see euclideanClusters). Chosen on thesis_angled: 0.04 splits the
    /// sparse far side of an angled joint off.
    double cluster_tolerance = 0.08;
    /// Split a cluster that a level support joins (splitAtSupport): two pipes side by side on a
    /// catwalk share one cluster through the catwalk's top between them (catwalk_twin, seed 93:
    /// one cluster 0.8-0.9 m wide per label in every cycle).
    bool split_at_support = true;
    /// [m] world point [x, y, z] where the pipe handler works (the well centre, the mousehole);
    /// empty: none. With it, each label's primary end (box_end/pose, pin_end/pose) is the one
    /// of its ends nearest this point among those fitted this cycle. A nearer end takes the
    /// place only when it is nearer by more than track_gate (two fits within track_gate are one
    /// end), so the choice holds.
    std::vector<double> handling_point;
    /// Without a handling_point: the primary pair is the box end and pin end of a connection
    /// being made (a pin hanging over a box, axes opposed) with the smallest stand-off, when
    /// there is one; otherwise (and when false) each label's best-fitting end (chooseInstance).
    bool primary_by_standoff = true;
    int max_instances = 3;            ///< clusters decided (the track's and the largest others)
    /// Other ends (several pipes at once) each label follows besides its own, at most; 0: only
    /// the primary pair. Each costs a tracked fit per cycle.
    int max_other_ends = 4;
    /// [m] a track follows the cluster with a point this close to its predicted origin; a
    /// decided instance joins the memory entry this close to its origin.
    double track_gate = 0.2;
    /// The best instance is taken only when the next one's mean cost is larger by at least this
    /// fraction; otherwise the label has no pose this cycle (two same-size pipes in the work
    /// zone: which one is meant is not in the data), and a track keeps its instance.
    double min_cost_margin = 0.04;
    /// Decisions an instance needs before it is chosen among several, and before it can take
    /// the place of the incumbent (the track's instance, or the one chosen last).
    int min_decisions = 3;
    int memory_decisions = 30;  ///< decisions averaged per instance (running mean)
    /// [m] Two instances whose tool-joint radii, measured at their decisions (radiusOffset in
    /// profile_registration.hpp) and averaged over at least min_decisions of them, differ by more than this
    /// are two pipe sizes: the one further from the model's radius does not compete (0: off).
    /// Relative, because a rig's common depth offset scales every measured radius alike (the
    /// kinect_v2_field profile measured the right joint more than 2.5 mm off in some decisions);
    /// so a lone joint of another size is not recognised. A 4.5" pipe's 6 1/4" joint is 4.75 mm
    /// thinner than a 5" pipe's 6 5/8" one, a worn joint at most 1 mm thinner than nominal
    /// (docs/conventions.md, sensor profiles): 2.5 mm lies between (chosen on cluttered).
    double radius_difference = 0.0025;
    double memory_s = 3.0;      ///< [s] an instance not decided for this long is forgotten
    /// [m] A decided fit whose axis is reversed against a remembered instance (min_decisions
    /// decided), lies within track_gate of that instance's axis line and at most this far along
    /// it, and has no instance of its own direction within track_gate, is that instance fitted
    /// flipped (a lying pin end whose pin passes for the tube), not another end: it is not
    /// taken (0: off). A flipped pin fit lies about a tong length (0.23-0.27 m) along the axis
    /// from the true one (catwalk_twin seed 191); 0.4 m leaves room for longer box tongs and
    /// stays below the 0.9 m between the ends of the shortest pipe the scenes hold.
    double reversal_reach = 0.4;
    /// Fits a new other end needs before it is published (1: from its first). An end that was
    /// the primary's comes confirmed. A one-cycle fit of a cluster that is no end (a tube's
    /// side, a pin fitted flipped before its end is decided) is then never published; a real
    /// end appears one cycle later. 2 was chosen on catwalk_twin seeds 93, 190 and 191 (the
    /// published ends off their label's ends, 1-3 per 10 s, were each a one-cycle other end);
    /// held out on catwalk_twin 197-199 and drill_floor 197-198 (docs/seeds.md).
    int confirm_fits = 2;
  } instances;

  /// Point-set limits and the robust cylinder-axis fit (radius known: tool-joint OD / 2).
  struct AxisFit {
    size_t min_points = 40;   ///< fewer carved points: the end is invalid
    size_t max_points = 400;  ///< larger sets are subsampled (deterministically) for the axis
    int hypotheses = 12;      ///< local-PCA RANSAC hypotheses besides the global PCA
    /// Directions sampled over the hemisphere (each scored with its circle centre; the best 4
    /// are refined too); 0 = off.
    int direction_samples = 64;
    double neighbourhood = 0.25;     ///< [m] radius of the local PCA of a hypothesis
    double inlier_threshold = 0.02;  ///< [m] |distance to axis - radius| of a cylinder inlier
    int iterations = 8;              ///< Gauss-Newton iterations per hypothesis
    uint32_t seed = 1;               ///< random sampling seed (deterministic)
    /// Support-plane removal before the fit (a floor or catwalk around the joint): the plane
    /// with the most points within plane_threshold [m] (RANSAC) is left out of the axis fit when
    /// it holds at least plane_min_fraction of the points and its inliers spread by a standard
    /// deviation of at least plane_min_extent [m] along the plane's narrower direction (the band
    /// of the joint's side near a tangent plane spreads about 0.4 radius, an end face 0.7
    /// radius or less). plane_iterations = 0: off.
    int plane_iterations = 60;
    double plane_threshold = 0.02;
    double plane_min_fraction = 0.1;
    double plane_min_extent = 0.06;
  } axis_fit;

  /// Registration against the model profile (body of revolution, roll-free: 5 DoF).
  struct ProfileFit {
    double search_step = 0.003;  ///< [m] 1-DoF axial search step (coarse pass: 2.5 steps)
    /// Pixels whose camera ray misses the model next to the joint's sides (lateral noise moved
    /// them outward) count in the refinement at their closest-point distance (refineProfile)...
    bool silhouette_points = true;
    /// ...while the fit explains at least this fraction of its points (chosen on dark_steel, whose
    /// fits explain fewer: the mixed pixels at its silhouette tilted a box-end fit outside its
    /// 3-sigma).
    double silhouette_min_inlier_fraction = 0.7;
    /// [mm] Per point, the final fit's depth sigma grows toward grazing incidence by this times
    /// z^1.5 (theta / (pi/2 - theta))^2 (the Kinect v2 model's incidence term, 0.1, times
    /// noise.scale: 0.12). Off by default: on the simulated thesis_angled it reduces the tilt
    /// bias but leaves the position to the frontal points, which the cameras' depth offsets
    /// move (docs/results.md). A rig whose depth offsets are calibrated out may prefer it.
    /// 0 = off.
    double incidence_noise = 0.0;
    /// The reflectivity the final fit predicts each point's returned amplitude with
    /// (a = reflectivity cos(theta) / range^2 at the model's surface): the point's depth is
    /// corrected by the Kinect v2's weak-return bias and its sigma is at least the weak-return
    /// noise (kinect_v2::AmplitudeModel, fitted to a real Kinect v2). 0 = off, the default: on
    /// the fitted sensor model (catwalk_horizontal, seed 1, 5 s) 0.6 (yellow paint) brought the
    /// box end from 9.8 to 5.1 mm but left the pin end at 12 mm with 93 % inside 3-sigma, and
    /// on frames without the bias it moved that pin end 32 mm: the correction is as large as
    /// the bias and only as good as the assumed reflectivity (mud patches return less).
    double reflectivity = 0.0;
    /// [1/m^2] the amplitude whose bias the rig's depth calibration removed (a calibration
    /// target at the working range returns less than the bias model's lowest amplitude, 0.0194);
    /// 0: an uncalibrated sensor, nothing removed.
    double bias_reference = 0.0194;
    double truncation = 0.025;   ///< [m] robust cost: residuals beyond this cost as much as this
    /// [m] only the part of the tong within (tong length - wear_margin) of the shoulder is trusted
    /// in the refinement (worn joints are up to 20 mm shorter than nominal).
    double wear_margin = 0.03;
    /// [m] the points less than this above a level support under the joint (a floor or
    /// catwalk, found among the end's points at the decision: findLevelSupport, as configured in
    /// axis_fit.plane_*), or below it, are left out of the pose refinement: there the floor and
    /// the joint's foot cannot be told apart, and the floor's points tilt the axis. The
    /// decisions and the fit's cost still judge every point. 0: off.
    double support_clearance = 0.01;
    int iterations = 12;  ///< IRLS Gauss-Newton iterations of the final refinement
    int hypothesis_iterations = 8;  ///< of each hypothesis before the decision
    double huber = 2.0;   ///< Huber threshold in units of the point's noise sigma
    /// A detection's label is replaced when the other model's cost is lower by this fraction.
    double label_margin = 0.15;
    size_t search_points = 250;  ///< points used in the 1-DoF axial search
    /// Points (deterministic subsample) of the coarse stages: the hypotheses' refinement, the
    /// winner's fine axial scan and its first refinement iterations; the last
    /// `polish_iterations` use every point.
    size_t coarse_points = 400;
    int polish_iterations = 3;
    size_t max_points = 3000;    ///< larger end clouds are subsampled (deterministically)
    /// Search the axial position with a 0.3 m longer tong (no pull from a worn joint's taper).
    bool long_tong_search = false;
    double max_rms = 0.02;             ///< [m] a fit with a larger inlier RMS residual is invalid
    /// A fit with fewer inliers (of the points the refinement used: those above a support) is
    /// invalid (chosen between painted joints' fits and dark steel's, which explain fewer).
    double min_inlier_fraction = 0.6;
    /// [m], [rad] a fit whose reported std along the axis / of the tilt is larger is invalid (the
    /// points do not determine the pose: nothing is published rather than a guess).
    double max_axial_std = 0.05;
    double max_tilt_std = 0.1;
  } profile_fit;

  /// Free-space check against the depth images, scored symmetrically for every hypothesis (both
  /// models x both axis directions, each at its best position along the axis): score = sum over
  /// the points of min(d^2, truncation^2) / truncation^2 + pixel_weight * (depth pixels on which
  /// the model claims a surface that the camera saw through). Decides the axis direction, the
  /// label and the position along the axis.
  struct FreeSpace {
    bool enabled = true;
    bool decide_hypotheses = true;  ///< the seen-through pixels enter the decision
    bool axial_scan = true;         ///< scan the position along the axis with the score
    /// A seen-through depth pixel costs this many unexplained points.
    double pixel_weight = 1.0;
    /// [m] depth beyond the model surface that counts as seen-through (at least; 3 sigma of the
    /// depth noise at the sample's range and incidence when larger).
    double margin = 0.03;
    double sample_spacing = 0.012;  ///< [m] model surface samples
    double tube_length = 0.22;      ///< [m] tube below the taper that the checked model includes
    /// Model samples seen at a smaller cosine of incidence are not judged (grazing).
    double min_cos_incidence = 0.3;
    double axial_range = 0.04;    ///< [m] +- scan of the position along the axis
    double decision_step = 0.01;  ///< [m] step of every hypothesis's scan (then step / 2)
    double axial_step = 0.002;    ///< [m] step of the winner's fine scan
    /// The end is invalid (not published) when the flipped axis direction of the winning model
    /// scores less than this much worse (unexplained-point units): reject rather than guess.
    double min_direction_margin = 20.0;
    /// When no point constrains the position along the axis (a hanging end seen from above:
    /// only the tong's cylinder), the position is the scan's. It is trusted only when the
    /// score 1 cm either side of it is at least this much higher than at it; a position that
    /// the score contradicts (lower by more than 8 units 1 cm away) is invalid. Measured on the
    /// simulator: hanging pins (stabbing) go down to -7, the flipped poses of dark_steel to -10.
    double min_axial_contrast = -8.0;
  } free_space;

  /// The position along the axis from the depth pixels around the end, read as the sensor reads
  /// a depth step (edge_likelihood.hpp; docs/measurement_model.md): after the refinement, the
  /// end is moved along its axis to where the pixels' likelihood is highest. The refinement's
  /// points at the end face and rims are mixed or missing pixels, read behind the surface; this
  /// is the stage that does not trust them.
  struct Edges {
    bool enabled = true;
    /// [m] +- scan from the refinement's position (its bias on the design seeds 400-402 was
    /// 2-11 mm at 6.5 m, below the pixel footprint of 18 mm), in 6 mm, then 3 and 1 mm steps.
    double scan_range = 0.018;
    /// What each kind of pixel reads, as a prior worth prior_pixels pixels; the judged pixels'
    /// own counts at the refinement's pose decide (a driver without an edge filter, a camera
    /// that reads every step cleanly, the simulator's ideal profile).
    /// P(no depth) beside a model step: the real Kinect v2's board silhouette (scripts/
    /// sensor_check, docs/sensor_check.md): 1.0-1.2 of a crossing's 2 transition pixels invalid.
    double step_invalid = 0.5;
    /// P(no depth) on the model away from its steps: weak returns (none on the real board's
    /// bright squares at 0.75-1.75 m; a few per cent on yellow paint at 6.5 m).
    double surface_invalid = 0.05;
    /// P(a pixel away from steps reads through the model, or a surface where it has none).
    double wrong = 0.01;
    /// Worth a tenth of a camera's judged pixels around a box end at 6.5 m (about 200): the
    /// counts decide; not tuned.
    double prior_pixels = 20.0;
    /// The scan runs only where at least this share of the pixels beside the model's steps is
    /// missing (and 3 times the share on the model away from them): a ToF sensor whose driver
    /// drops edge pixels, as the real Kinect v2 does (half of them). Where the edges read mixed
    /// but complete, the scan moved the ends further off than the refinement (thesis_vertical's
    /// box end 3-5 mm further down, stabbing's 0.5-1.3 mm; the simulator's edges before their fit
    /// to the real sensor, 35 % mixed, none dropped). Per decision on the design seeds 400-402
    /// (100 cycles each): those edges 0.02-0.26 (10th-90th percentile; weak returns at grazing
    /// steps), the fitted edges 0.37-0.57 (cluttered's box end down to 0.27).
    double min_step_missing = 0.3;
    /// A camera is left out of the scan where its own step pixels are missing less than this
    /// share, or less than 3 times its pixels on the model: something in front of the end in
    /// its view (cluttered's barrel and person: one camera's box end read 0.00-0.18 missing
    /// beside steps, 0.2-0.36 on the model) drowns the others' edges in the pooled count, which
    /// kept the scan off cluttered's box end. Half of min_step_missing: one camera judges 50-80
    /// step pixels around a box end at 6.5 m, its share +-0.06 (thesis_vertical's cameras read
    /// 0.24-0.61). Cluttered's box end 10.1-11.6 -> 6.2-8.3 mm, its pin end 3.8-5.3 -> 2.9-3.6
    /// mm; the other scenes' ends within +-0.4 mm (design seeds 400-402). The whole of
    /// min_step_missing per camera gave cluttered's box end 7.7, 6.4, 8.1 mm against 7.1, 6.2,
    /// 8.3; a test on the on-model share alone 10.6 mm (seed 400).
    double camera_min_step_missing = 0.15;
    /// ...as long as this many cameras remain: on fewer the scan is not run. With two allowed,
    /// the scan moved cluttered's pin end further off (design seed 402: 3.7 -> 4.7 mm).
    int min_cameras = 3;
    /// [m] nor where the end moves by more than this between the cycle's earliest and latest
    /// camera frame (its track's mean speed times their stamps' spread): the scan judges every
    /// camera's pixels at one pose. The moving scene's hoisted pin end (0.2 m/s, 30 Hz cameras
    /// out of step: up to 6.6 mm) read 6.0-7.2 mm fresh median with the scan, 3.4-4.4 without,
    /// and 3.4 with the scan on synchronised cameras (design seeds 400-402; synchronised: 400).
    /// A third of a depth pixel's footprint at 6.5 m; not tuned.
    double max_motion = 0.002;
    /// [m] the judged region: from region_below under the end's top (the box's end face, the
    /// pin's nose) along its axis to region_above beyond it, the model's radius across.
    /// 0.03-0.15 below gave the same box ends on thesis_vertical's design seeds 400-402.
    double region_below = 0.08;
    double region_above = 0.03;
  } edges;

  /// Depth noise model (Fankhauser et al. 2015, head-on): sigma = scale * (1.5 - 0.5 z + 0.3 z^2)
  /// [mm, z in m], at least min_sigma.
  struct Noise {
    double scale = 1.2;
    double min_sigma = 0.003;  ///< [m]
    /// [DN per 1/m^2] the frames' amplitude image (SensorFrame.amplitude) in units of the
    /// noise model's amplitude a = reflectivity cos(theta) / range^2: 40260 for a Kinect v2
    /// through kinect2_bridge (kinect_v2::kDnPerAmplitude, fitted on the real recording).
    double amplitude_scale = 40260.0;
    /// Use the frames' amplitude: each pixel's weak-return bias taken out of its depth (the
    /// Kinect v2's, fitted on the real sensor; docs/measurement_model.md). false: the amplitude
    /// is ignored. On by default: on rigs whose cameras see the joints at other ranges than the
    /// depth calibration's, the bias is the largest error (design seeds 400-402, held out
    /// 410-412: catwalk_horizontal's pin end, close_single, four_high; docs/results.md). Frames
    /// without amplitude are used as before.
    bool amplitude_model = true;
  } noise;

  /// Covariance = Hessian^-1 * reduced chi^2 * inflation, plus per-axis floors (end frame).
  struct Covariance {
    double inflation = 4.0;          ///< correlated noise (neighbour pixels, per-camera offsets)
    double min_lateral_std = 0.003;  ///< [m] added across the axis
    double min_axial_std = 0.004;    ///< [m] added along the axis
    double min_tilt_std = 0.006;     ///< [rad] added about the end's x and y
    double roll_variance = 1e3;      ///< [rad^2] about the axis (unobservable)
    /// The rig calibration's uncertainty per camera (1 sigma of its extrinsics' translation [m]
    /// and rotation [rad] error): a bias that no filter removes, added to the published
    /// covariance (calibrationCovariance in covariance.hpp). The defaults are the field
    /// calibration of the simulator's kinect_v2_field profile (5 mm, 0.2 deg); set them from your
    /// calibration's residuals (0: extrinsics exact).
    double extrinsic_translation_std = 0.005;
    double extrinsic_rotation_std = 0.0035;
  } covariance;

  /// Temporal filter of each end's pose across cycles (temporal_filter.hpp): a constant-velocity
  /// Kalman filter on the origin and a random-walk filter on the axis. Off: each cycle stands
  /// alone.
  struct Temporal {
    bool enabled = true;
    /// [m^2/s^3] white-acceleration spectral density: larger follows sudden moves faster,
    /// smaller smooths more; a move beyond gate_sigma of the prediction restarts the filter.
    double acceleration_density = 0.01;
    /// [rad^2/s] random-walk density of the axis direction.
    double tilt_rate_density = 0.0001;
    /// [m/s] prior velocity std at a (re)start.
    double max_speed = 1.0;
    /// A measurement further than this many sigma from the prediction (position, or tilt)...
    double gate_sigma = 4.0;
    /// ...is not published until this many more measurements agree with it (a real move: the
    /// filter restarts from the last); 0 = the filter restarts from it at once.
    int confirmations = 1;
    /// A new track's first pose (the first, or after a gap) is held the same way: a single
    /// wild fit is never published. Chosen on dark_steel (design seed 400, 10 s): its one
    /// fresh box-end fit in 300 cycles lay 0.22 m and 88 deg off, with a reported sigma (18 mm,
    /// 2.6 deg) inside the range of right fits in the thesis scenes (design seeds 400-402), and
    /// was published for 6 cycles. Costs every track its first cycle.
    bool confirm_start = true;
    /// [s] a longer gap between measurements restarts the filter.
    double max_gap = 0.5;
  } temporal;

  /// Tracking: while a label's last cycle gave a valid pose, this cycle starts from it (moved on
  /// by its velocity) with its model and axis direction, and skips the cylinder-axis fit, the
  /// hypothesis search and the model/direction decision (most of a cycle's time). The full
  /// decision runs again when the refined pose leaves the prediction by more than max_angle or
  /// max_offset, after a gap, and always when tracking is off; at least every `redecide_every`
  /// cycles of a track the model and direction are decided again on the track's axis (the
  /// hypotheses without the support-plane removal and the cylinder-axis fit).
  struct Tracking {
    bool enabled = true;
    /// Cycles between full decisions of a continuing track (for the pin end's label one more
    /// when the box end's is due for one in that cycle, so that the two ends' periodic decisions
    /// fall in different cycles).
    int redecide_every = 10;
    double max_gap = 0.5;      ///< [s] a longer gap since the track's last pose ends it
    double max_angle = 0.08;   ///< [rad] largest angle between the refined axis and the track's
    double max_offset = 0.04;  ///< [m] largest move of the refined origin from the prediction
    /// [m] largest move of the prediction (velocity from the last two poses times the gap)
    double max_prediction = 0.05;
  } tracking;

  /// Drift watch (drift_watch.hpp): after each cycle's fit, each camera's points are aligned to
  /// the fitted model of every valid end it saw (a 3-DoF translation); the result, split into a
  /// shift along the camera's view ray and a rotation (the lateral offset over the range), is
  /// averaged over time per camera. A camera whose average passes a limit is flagged (a bumped
  /// camera: its published calibration no longer holds) and, with leave_out, its points leave
  /// the fit until it agrees again; it is measured meanwhile. Measuring changes no pose.
  struct Drift {
    bool enabled = true;
    /// [s] capture-time constant of each camera's running (exponentially weighted) estimate.
    double time_constant = 1.0;
    /// [m] a camera whose running shift along its view ray is larger is flagged.
    double max_ray_shift = 0.01;
    /// [deg] ...or whose running rotation (lateral offset / range) is larger.
    double max_rotation = 0.3;
    /// A flagged camera is cleared when both figures fall below this fraction of their limits.
    double release_fraction = 0.5;
    /// [s] capture time over which each camera's own disagreement on each set of ends it
    /// measures (box, pin, both) is learned from its first observation of that set (its mean
    /// becomes the camera's baseline there, and the flags above measure the change from it); no
    /// flag is raised while a camera has no learned set. Why a baseline: undisturbed, a
    /// camera's points disagree with the fused fit by up to 14 mm along the ray and 0.3 deg
    /// (thesis_angled, catwalk_horizontal, kinect_v2_calibrated, seed 81, even with the true
    /// rig: the sensor's depth bias differs between the cameras' views), as much as a bump.
    /// 2 s: a baseline learned in 1 s was off its camera's long-run disagreement by up to 5 mm
    /// (the first second's fits are settling), which the noise then pushed past max_ray_shift
    /// (seed 81, 40 s, thesis_angled and catwalk_horizontal with the amplitude model: largest
    /// running shift 9.2 and 9.0 mm with 1 s, 7.0 and 6.0 with 2 s, 5.5 and 7.0 with 3 s; 3 s
    /// would leave a camera bumped in its first 3 s to the absolute limit alone).
    double learn_time = 2.0;
    /// [s] after learning, the baseline follows the camera's disagreement with this capture-time
    /// constant while it is not flagged (a pipe that moves changes each view's bias slowly);
    /// frozen while flagged. 0: never after learning. 30 s: what a baseline learned a little off
    /// keeps of its error fades (seed 81 as above, with learn_time 2: 7.0 and 6.0 -> 6.1 and
    /// 5.6 mm), while a bump's 2 s to its flag moves the baseline by under 7 % of the bump.
    double baseline_time_constant = 30.0;
    /// A camera whose running disagreement itself (not its change) exceeds this many times
    /// max_ray_shift or max_rotation is flagged too: a camera bumped before the watch learned
    /// (3: 30 mm, 0.9 deg; undisturbed, cluttered's cam4 reads 20 mm, seed 1, and the seed-81
    /// runs above 14 mm and 0.3 deg).
    double absolute_factor = 3.0;
    /// [m] a camera's points further than this from the fitted model's surface are not used
    /// (more than the shifts to be measured: a 0.5 deg bump moves points 5.7 cm at the
    /// thesis_lab rig's 6.5 m); a second pass keeps those within 0.3 gate of the surface moved
    /// by the first pass's shift.
    double gate = 0.1;
    /// A camera is measured on an end only with at least this many points within the gate.
    size_t min_points = 30;
    /// Flagged cameras' points leave the fit (their boxes still vote in the carving) until they
    /// agree again. With the learned baseline no camera was flagged on the undisturbed seed-81
    /// runs of thesis_vertical, thesis_angled, catwalk_horizontal and stabbing (largest change
    /// 8 mm and 0.13 deg); scripts/bench_drift checks held-out seeds.
    bool leave_out = true;
    /// ...while at least this many cameras that are not left out remain in the cycle.
    int min_cameras = 3;
  } drift;

  /// thesis_baseline parameters (thesis chapter 3.4).
  struct Baseline {
    int layers = 3;                   ///< concatenated clouds (cycles)
    double square_size = 0.20;        ///< [m] side of the square kept around the centroid
    double band_min_z = 0.45;         ///< [m] world height band used for the centroid
    double band_max_z = 1.5;          ///< [m]
    int icp_iterations = 200;         ///< PCL ICP maximum iterations
    int icp_runs = 10;                ///< ICP runs per cycle
    double model_spacing = 0.006;     ///< [m] model cloud point spacing (uniform sampling)
    double prealign_distance = 0.05;  ///< [m] re-pre-align when the model is further than this
    size_t min_points = 30;           ///< fewer segmented points: invalid
    double position_std = 0.03;       ///< [m] reported std per axis (the thesis reports none)
    double tilt_std = 0.05;           ///< [rad] reported std about x and y
  } baseline;
};

struct PipeCatalog;
/// Resolves the pipe types from the catalogue: config->dims becomes the entry pipe_type's
/// geometry, except the tool_joint/* figures that differ from their defaults (overrides), and
/// config->candidates the entries of pipe_types ("all": every one; pipe_type's with its
/// overrides). Throws InputError naming the catalogue and the name: an unknown name, pipe_type
/// not among pipe_types, an overridden geometry that validateDimensions rejects. Nothing to do
/// with pipe_type "".
void resolvePipeTypes(EstimatorConfig* config, const PipeCatalog& catalog);
/// Checks every field against its range in the parameter table and the checks across fields
/// (estimator_config.cpp); throws InputError naming the key (e.g. "carving/min_cameras").
void validateConfig(const EstimatorConfig& config);

}  // namespace drill_pipe_pose
