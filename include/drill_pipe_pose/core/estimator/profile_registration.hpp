#pragma once
// Stages "hypotheses" and "refinement": the roll-free (5-DoF) registration of the tool-joint
// profile to an end's points, its residuals, and the radius check of a fit.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "drill_pipe_pose/core/estimator/axis_fit.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"

namespace drill_pipe_pose {

/// The tool-joint radius that a fit's inlier points imply, relative to the model's.
struct RadiusCheck {
  bool ok = false;     ///< enough points on the OD, and they fix the radius
  double offset = 0;   ///< [m] measured minus model radius (a thinner joint: negative)
  double std = 0;      ///< [m] its standard deviation (from the residuals' scatter)
  size_t points = 0;   ///< inlier points on the OD
  double extent = 0;   ///< [m] their span along the axis
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
/// Only points whose model surface lies at most `z_max` along the axis count (the tube: below
/// the taper, not a pin cone that passes through the tube's radius).
RadiusCheck radiusOffset(const ProfileModel& model, double od_radius,
                         const Eigen::Vector3d& origin, const Eigen::Vector3d& z,
                         const std::vector<Eigen::Vector3f>& points,
                         const std::vector<Eigen::Vector3f>& eyes,
                         const std::vector<uint8_t>& inlier_mask,
                         double z_max = std::numeric_limits<double>::infinity());

/// Mean truncated squared residual [m^2] (profileResidual) of the points against `model` placed
/// at (origin, z); `eyes` as in refineProfile.
double profileCost(const std::vector<Eigen::Vector3f>& points, const ProfileModel& model,
                   const Eigen::Vector3d& origin, const Eigen::Vector3d& z, double truncation,
                   const std::vector<Eigen::Vector3f>* eyes = nullptr);

}  // namespace drill_pipe_pose
