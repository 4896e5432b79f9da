#pragma once
// The likelihood of a model pose from the depth pixels around its end, with the pixels beside
// the model's depth steps (its silhouette, the end face's rims, the bore) read as a ToF sensor
// reads them: missing or mixed, about half each, whatever their depth.

#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"

namespace drill_pipe_pose {

/// [m] a range difference between neighbouring pixels of the model's rendered depth that makes
/// a depth step (a ray that misses the model beside one that hits it is one too): the jump that
/// the real board's silhouette measures were taken at (docs/sensor_check.md).
constexpr double kEdgeStepJump = 0.05;

/// The region of each camera's depth image that the likelihood judges for an end near
/// T_world_end: the end frame's box |x|, |y| <= radius, z from edges.region_below under the
/// end's top (the box's end face, the pin's nose) to edges.region_above beyond it, grown by
/// `reach` [m] along the axis, projected, a pixel added, cut to the crop. One
/// scan judges every pose on the same pixels. {0, 0, 0, 0}: the camera does not see the end.
std::vector<std::array<int, 4>> edgeRegions(const ProfileModel& model, double radius,
                                            const Eigen::Isometry3d& T_world_end,
                                            const std::vector<CycleCamera>& cameras,
                                            const EstimatorConfig::Edges& edges, double reach);

/// What the judged pixels of each kind read, as negative log-probabilities. The kinds:
/// - kOn: on the model away from its steps (as modelled: on the surface or in front of it, an
///   occluder; other: more than max(margin, 3 sigma) behind it, seen through);
/// - kStepFront, kStepBack: beside a model step (a 4-neighbour's rendered range differs by more
///   than kEdgeStepJump, or one hits the model and the other misses), the pixels a ToF sensor
///   mixes or drops: the one whose own ray meets the front-most surface of the five, and the
///   one that sees past it (outcomes: on that front-most surface, or behind it);
/// - kOff: off the model away from its steps (as modelled: the background; other: a surface
///   within max(margin, 3 sigma) of the model's, where the model has none).
/// Missing pixels are an outcome of their own: beside a step they are expected.
struct EdgeOutcomes {
  enum Kind { kOn = 0, kStepFront = 1, kStepBack = 2, kOff = 3, kKinds = 4 };
  enum Outcome { kMissing = 0, kAsModelled = 1, kOther = 2 };
  std::array<std::array<double, 3>, kKinds> nll{};  ///< [kind][outcome] nats
  /// The share of missing pixels beside the steps and on the model away from them, as counted
  /// (without the prior): a ToF sensor's edge signature when the first is much the larger.
  double step_missing = 0.0, on_missing = 0.0;
};

/// The outcomes' probabilities as the pixels of `regions` read them with the model at
/// T_world_end (a pose within a pixel of the truth), with the configured figures (edges.*) as a
/// prior worth edges.prior_pixels pixels: what this sensor does at this end's steps today (a
/// driver's edge filter, the scene's materials), not assumed.
EdgeOutcomes estimateEdgeOutcomes(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                                  const std::vector<CycleCamera>& cameras,
                                  const std::vector<std::array<int, 4>>& regions,
                                  const EstimatorConfig::Edges& edges,
                                  const EstimatorConfig::Noise& noise, double margin);

/// Negative log-likelihood [nats] of the judged pixels of `regions` (edgeRegions: those away
/// from each region's border) given `model` at T_world_end: the model rendered into each
/// region, each pixel's kind and outcome (EdgeOutcomes) priced by `outcomes`.
double edgeNegLogLikelihood(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                            const std::vector<CycleCamera>& cameras,
                            const std::vector<std::array<int, 4>>& regions,
                            const EdgeOutcomes& outcomes, const EstimatorConfig::Noise& noise,
                            double margin);

}  // namespace drill_pipe_pose
