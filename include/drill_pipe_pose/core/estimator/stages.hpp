#pragma once
// The stages of the estimator pipeline, exposed for unit tests and tools. Everything is in the
// world frame [m] unless the name says otherwise.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

/// A cut-out point.
struct CloudPoint {
  Eigen::Vector3f p_world;  ///< [m] world
  float sigma = 0.01f;      ///< [m] expected depth-noise std of this point
  uint16_t camera = 0;      ///< index of the camera (in the cycle's camera list)
};

/// A validated camera of one cycle: models, transforms, boxes (already confidence-filtered).
struct CycleCamera {
  std::string name;
  PinholeCamera depth;
  PinholeCamera color;
  DepthImage image;
  Eigen::Isometry3d T_world_depth = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_color_depth = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_color_world = Eigen::Isometry3d::Identity();  ///< derived
  std::vector<DetectionBox> boxes;
  /// Whether this camera has at least one box of each label.
  std::array<bool, kNumEnds> has_label{{false, false}};
  /// [u0, v0, u1) x [v0, v1) of the delivered depth image: the pixels a cropping sensor node
  /// sends (depthCropRect). Depth beyond the cut-out (occlusion, seen-through pixels) is read
  /// only there, so that full and cropped depth give the same poses. Empty without boxes.
  std::array<int, 4> crop{{0, 0, 0, 0}};
};

/// Builds a CycleCamera from one input; throws InputError naming the camera and the field.
CycleCamera makeCycleCamera(const SensorFrameData& frame, const Eigen::Isometry3d& T_world_depth,
                            const Eigen::Isometry3d& T_color_depth, float min_confidence);

/// The depth-pixel rectangle [u0, u1) x [v0, v1) (delivered depth image) that can register into
/// colour box `box` grown by margin_px for depths in [min_range, max_range]: the box's corner
/// rays at both ranges projected into the depth image. False when it misses the image.
bool depthRectOfBox(const CycleCamera& cam, const DetectionBox& box, double margin_px,
                    double min_range, double max_range, std::array<int, 4>* rect);

/// Per-camera cut-out: every valid depth pixel in the frustum of a box whose registration into
/// the colour image falls inside that box (grown by cfg.box_margin_px), to world, inside the work
/// zone. Each pixel is emitted at most once per label (duplicate boxes). Appends to out[label].
void cutOutCamera(const CycleCamera& cam, uint16_t camera_index, const EstimatorConfig& config,
                  std::array<std::vector<CloudPoint>, kNumEnds>* out);

/// Depth noise std [m] at depth z [m] (config.noise).
float depthSigma(const EstimatorConfig::Noise& noise, double z);

/// The depth noise's growth [m] toward grazing incidence (the Kinect v2 model's incidence term,
/// Fankhauser et al. 2015): coefficient_mm x range^1.5 x (theta / (pi/2 - theta))^2 mm, theta
/// the angle between the ray and the surface normal, at most 84 deg. Added to depthSigma where
/// the surface is known (profile_fit.incidence_noise).
double incidenceSigma(double coefficient_mm, double range, double cos_incidence);

/// Visual-hull carving of the points of `label` (see EstimatorConfig::Carving).
std::vector<CloudPoint> carve(const std::vector<CloudPoint>& points, EndLabel label,
                              const std::vector<CycleCamera>& cameras,
                              const EstimatorConfig::Carving& config);

/// Clusters of `points`: connected occupied cells of a grid of edge `tolerance` [m] (cells that
/// touch, corners included, join; two points closer than `tolerance` always share a cluster,
/// points up to 2 sqrt(3) tolerance apart may). Clusters of at least `min_points`, largest
/// first, as indices into `points` (ascending within a cluster). Deterministic.
std::vector<std::vector<size_t>> euclideanClusters(const std::vector<CloudPoint>& points,
                                                   double tolerance, size_t min_points);

/// The tool-joint radius that a fit's inlier points imply, relative to the model's.
struct RadiusCheck {
  bool ok = false;     ///< enough points on the OD, and they fix the radius
  double offset = 0;   ///< [m] measured minus model radius (a thinner joint: negative)
  double std = 0;      ///< [m] its standard deviation (from the residuals' scatter)
  size_t points = 0;   ///< inlier points on the OD
};

/// What the decisions have shown about one instance of a label (a cluster of its carved points,
/// at one place) over the last cycles (EstimatorConfig::Instances).
struct InstanceMemory {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< the last decided fit's origin
  /// Mean fit cost (the refined fit's mean truncated squared residual [m^2]) of the last
  /// `decisions` decisions (running mean).
  double mean_cost = 0.0;
  int decisions = 0;     ///< at most instances.memory_decisions
  /// Mean tool-joint radius offset (RadiusCheck::offset [m]) of the last `radius_samples`
  /// decisions that measured it (running mean, at most instances.memory_decisions).
  double radius_offset = 0.0;
  int radius_samples = 0;
  int64_t stamp_ns = 0;  ///< the last decision's cycle
  bool chosen = false;   ///< the label's end was this instance at its last decided pose
};

/// The entry of `memory` whose tool joint shows `entry` to be another pipe size, or null: both
/// have at least min_decisions radius measurements, the other's mean is nearer the model's
/// radius, and the two differ by more than radius_difference (never when that is 0).
const InstanceMemory* otherSize(const InstanceMemory& entry,
                                const std::vector<InstanceMemory>& memory,
                                const EstimatorConfig::Instances& config);

/// One instance decided this cycle, for chooseInstance.
struct InstanceFit {
  bool competes = false;  ///< a valid fit that may be the label's end (the caller decides)
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double cost = 0.0;  ///< ProfileFitResult::cost
  RadiusCheck radius;  ///< the fit's radius check (not ok: not measured)
};

/// The choice among a label's instances: `index` into the fits, or -1 with `reason`.
struct InstanceChoice {
  int index = -1;
  std::string reason;
};

/// Chooses a label's end among its instances decided this cycle (`fits`; `track` is the index
/// of the one its track followed, or -1) and updates `memory` (entries not decided for
/// instances.memory_s are forgotten first). Each competing fit's cost joins its memory entry
/// (the one within instances.track_gate; a new one otherwise), and instances compete by their
/// entries' mean cost:
///  - an entry not fitted this cycle whose place still holds at least `min_points` of the
///    label's cut-out points (`points_near(origin, radius)`) competes too when it has
///    min_decisions decisions: when it is the best, none is chosen (a worse one is not taken in
///    its place);
///  - an instance whose tool-joint radius (each fit's `radius`; the entry's mean over at least
///    min_decisions of them) differs by more than instances.radius_difference from another
///    entry's that is nearer the model's is another pipe size (otherSize): it does not compete
///    (when that leaves none, the reason says so);
///  - the incumbent (the track's instance when it competes, else the entry chosen last) keeps
///    its place unless another is better by instances.min_cost_margin over at least
///    instances.min_decisions decisions;
///  - otherwise none is chosen while the best has fewer than min_decisions decisions and
///    others compete - or, without an incumbent, while any other instance has fewer, counting
///    an entry with fewer whose place still holds points and (while the best has fewer) a fit
///    of this cycle that does not compete - or while the runner-up is within min_cost_margin
///    (two alike).
/// Deterministic. `label` names the label in the reasons. With no competing fit, index -1 and
/// an empty reason (the caller explains).
/// How many of a label's cut-out points lie within `radius` [m] of `origin` [world].
using PointsNear = std::function<size_t(const Eigen::Vector3d& origin, double radius)>;
InstanceChoice chooseInstance(std::vector<InstanceMemory>* memory,
                              const std::vector<InstanceFit>& fits, int track, int64_t stamp_ns,
                              const PointsNear& points_near, size_t min_points,
                              const EstimatorConfig::Instances& config, const std::string& label);

/// An infinite line: a point on it and a unit direction (sign arbitrary).
struct AxisLine {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

/// Result of the robust known-radius cylinder fit.
struct AxisFitResult {
  bool ok = false;
  AxisLine axis;
  size_t inliers = 0;
  double rms = 0.0;  ///< [m] RMS of |distance to axis - radius| over inliers
};

/// Removes the points of a support plane (floor, catwalk) from an end's points, as configured in
/// `config` (plane_*): returns the indices of the points kept; all of them when no plane is found.
std::vector<size_t> removeSupportPlane(const std::vector<Eigen::Vector3f>& points,
                                       const EstimatorConfig::AxisFit& config);

/// Robust cylinder-axis fit with a known radius [m]: global-PCA and local-PCA (RANSAC) hypotheses,
/// each refined by Gauss-Newton with Tukey weights, best truncated cost wins.
AxisFitResult fitCylinderAxis(const std::vector<Eigen::Vector3f>& points, double radius,
                              const EstimatorConfig::AxisFit& config);

/// A level support (floor, catwalk: world +z up, REP 103) under an end whose cylinder-axis fit
/// is `axis` (tool-joint radius `radius` [m]): among the points more than plane_threshold off
/// that cylinder, the horizontal layer 2 plane_threshold thick with the most points, when it
/// holds at least plane_min_fraction of all the points, spreads by a standard deviation of at
/// least plane_min_extent [m] along its narrower horizontal direction, and has most of the other
/// points above it. `height` receives the layer's mean height [m, world z]. False when there is
/// none.
bool findLevelSupport(const std::vector<Eigen::Vector3f>& points, const AxisLine& axis,
                      double radius, const EstimatorConfig::AxisFit& config, float* height);

/// A tool-joint model as an open 2D profile (z, r) in its pipe-end frame, with the tube extended
/// beyond the model's truncation, an exact distance and a grid of distances for coarse searches.
class ProfileModel {
 public:
  ProfileModel() = default;
  ProfileModel(EndLabel label, const ToolJointDimensions& dims);

  EndLabel label() const { return label_; }
  /// Distance [m] from (z, r) to the profile; gradient (unit, in (z, r)) of the distance when
  /// `grad` is given, and the signed-free distance along it: d = grad . ((z, r) - closest).
  double distance(double z, double r, Eigen::Vector2d* grad = nullptr) const;
  /// Projective correspondence: the first intersection beyond s_min of the ray x(s) = q + s d
  /// with the model surface (end frame [m]; d unit, pointing away from the camera; s = 0 at the
  /// measured point q). False when the ray misses. `zr` receives the hit's (z, r), `normal` the
  /// unit (z, r) normal of the surface there, oriented toward the camera.
  bool rayHit(const Eigen::Vector3d& q, const Eigen::Vector3d& d, double s_min, double* s,
              Eigen::Vector2d* zr, Eigen::Vector2d* normal) const;
  /// Fast approximate distance from the grid (clamped outside it) [m].
  float coarseDistance(double z, double r) const;
  /// z [m] below which the model is not trusted (worn tong length): -(tong length - margin).
  double trustedMinZ(double wear_margin) const { return -(tong_length_ - wear_margin); }
  /// z range of the tool joint proper (box face / pin nose to the end of the taper) [m].
  double zMin() const { return z_min_; }
  double zMax() const { return z_max_; }

 private:
  struct Edge {
    Eigen::Vector2d a, b;
  };
  EndLabel label_ = EndLabel::kBoxEnd;
  std::vector<Edge> edges_;
  std::vector<double> edge_r2_max_;  ///< per edge, its largest radius squared
  double tong_length_ = 0.0, z_min_ = 0.0, z_max_ = 0.0;
  // Distance grid.
  double g_z0_ = 0, g_r0_ = 0, g_res_ = 0.0025;
  int g_nz_ = 0, g_nr_ = 0;
  std::vector<float> grid_;
  /// Per grid cell, the edges nearest to its centre and corners (-1 = none): exact distances at
  /// a fraction of the cost of visiting every edge.
  std::vector<std::array<int8_t, 4>> cell_edges_;
  std::vector<int8_t> all_edges_;
  double exactDistance(double z, double r, Eigen::Vector2d* grad, const int8_t* edges,
                       int n_edges) const;
};

/// Result of the profile registration of one hypothesis.
struct ProfileFitResult {
  bool ok = false;
  EndLabel label = EndLabel::kBoxEnd;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< [m] world, on the axis at the shoulder
  Eigen::Vector3d z = Eigen::Vector3d::UnitZ();      ///< unit axis (pipe-end z) in the world
  double cost = 0.0;  ///< mean truncated squared distance over all points [m^2]
  double rms = 0.0;   ///< [m] RMS distance of the inliers
  size_t inliers = 0;
  Eigen::Matrix<double, 5, 5> covariance = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 3, 5> basis;  ///< world directions of params: e1, e2 (lateral), z
  std::vector<uint8_t> inlier_mask;
};

/// For both directions of `axis`: a 1-DoF search along it for the shoulder position and a short
/// IRLS refinement; the better one is refined fully (5 DoF: 2 tilt, 3 position) against `model`.
/// Points [m, world] with noise sigmas [m].
ProfileFitResult fitProfile(const std::vector<Eigen::Vector3f>& points,
                            const std::vector<float>& sigmas, const AxisLine& axis,
                            const ProfileModel& model, const EstimatorConfig::ProfileFit& config);

/// IRLS refinement of the 5 DoF from (origin, z_axis) [world] for `iterations` iterations;
/// `lock_axial` keeps the origin's position along the axis (the Hessian still has that DoF).
/// With `eyes` (the world position of the camera that measured each point), a point is matched
/// to the model where its camera ray meets it (projective correspondence: unbiased by depth
/// noise near the joint's edges, where the closest surface is often not the one measured), and
/// to the closest model point only when its ray misses the model.
ProfileFitResult refineProfile(const std::vector<Eigen::Vector3f>& points,
                               const std::vector<float>& sigmas, const Eigen::Vector3d& origin,
                               const Eigen::Vector3d& z_axis, const ProfileModel& model,
                               const EstimatorConfig::ProfileFit& config, int iterations,
                               bool lock_axial = false,
                               const std::vector<Eigen::Vector3f>* eyes = nullptr);

/// Both directions of `axis`, each searched and refined: [0] along +direction, [1] along -.
/// The 1-DoF search uses `search_model` when given (e.g. the model with a long tong, so that the
/// taper of a worn joint - up to 20 mm closer to the shoulder - cannot pull the search).
std::array<ProfileFitResult, 2> fitProfileHypotheses(const std::vector<Eigen::Vector3f>& points,
                                                     const std::vector<float>& sigmas,
                                                     const AxisLine& axis,
                                                     const ProfileModel& model,
                                                     const EstimatorConfig::ProfileFit& config,
                                                     const ProfileModel* search_model = nullptr,
                                                     const std::vector<Eigen::Vector3f>* eyes = nullptr);

/// Symmetric free-space evidence of a model pose: the number of distinct depth pixels (summed
/// over the cameras) on which a camera-facing model surface sample (end frame, outward normals)
/// at T_world_end lands while the camera measured more than `margin` [m] behind it in the whole
/// valid 3x3 neighbourhood (the camera saw through the model) by more than max(margin, 3 sigma of
/// the depth noise at the sample's range and incidence). Samples seen at a cosine of incidence
/// below min_cos_incidence are not judged (grazing). An absolute count, not a fraction:
/// compared across hypotheses it charges each for every pixel its model claims wrongly, whatever
/// it hides below a floor or behind clutter. `predicted` receives the number of distinct pixels
/// the samples fall on.
size_t seenThroughPixels(const std::vector<OrientedPoint>& samples,
                         const Eigen::Isometry3d& T_world_end,
                         const std::vector<CycleCamera>& cameras, double margin,
                         const EstimatorConfig::Noise& noise, float min_cos_incidence,
                         size_t* predicted = nullptr);

/// Residual [m] of world point p against `model` placed at (origin, z): with `eye` (its camera's
/// position), the signed distance to the surface where the camera ray meets the model (huge when
/// the model hides the point), else - or when the ray misses - the closest-point distance.
/// `grad` receives the (z, r) normal of the residual in the end frame, `ray_hit` whether the
/// camera ray met the model, when given.
double profileResidual(const ProfileModel& model, const Eigen::Vector3d& p,
                       const Eigen::Vector3d& origin, const Eigen::Vector3d& z,
                       const Eigen::Vector3d& e1, const Eigen::Vector3d& e2,
                       const Eigen::Vector3f* eye, Eigen::Vector2d* grad = nullptr,
                       bool* ray_hit = nullptr);

/// The change of a residual with normal `grad` ((z, r), profileResidual) at the point q
/// (relative to the origin; zc = q . z its coordinate along the axis, u the unit radial
/// direction of q off the axis) per unit of the fit's 5 parameters: the origin along e1, e2, z
/// and the axis tilted toward e1, e2 (refineProfile).
Eigen::Matrix<double, 5, 1> profileJacobian(const Eigen::Vector3d& q, double zc,
                                            const Eigen::Vector3d& u, const Eigen::Vector3d& e1,
                                            const Eigen::Vector3d& e2,
                                            const Eigen::Vector2d& grad);

/// The radius offset of the tool joint's OD (radius od_radius in `model`) that best explains the
/// inlier residuals of a fit at (origin, z) together with a change of the pose (the pose
/// eliminated, so a shift of the axis does not pass for a radius). Another pipe size's joint
/// fits the model almost as well as the right one (its axis moves to make up for the radius),
/// but not its radius: 4.75 mm thinner for a 4.5" pipe's 6 1/4" joint beside a 5" pipe's.
RadiusCheck radiusOffset(const ProfileModel& model, double od_radius,
                         const Eigen::Vector3d& origin, const Eigen::Vector3d& z,
                         const std::vector<Eigen::Vector3f>& points,
                         const std::vector<Eigen::Vector3f>& eyes,
                         const std::vector<uint8_t>& inlier_mask);

/// Mean truncated squared residual [m^2] (profileResidual) of the points against `model` placed
/// at (origin, z); `eyes` as in refineProfile.
double profileCost(const std::vector<Eigen::Vector3f>& points, const ProfileModel& model,
                   const Eigen::Vector3d& origin, const Eigen::Vector3d& z, double truncation,
                   const std::vector<Eigen::Vector3f>* eyes = nullptr);

}  // namespace drill_pipe_pose
