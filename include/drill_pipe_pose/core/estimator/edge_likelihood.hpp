#pragma once
// The likelihood of a model pose from the depth pixels around its end, with the pixels beside
// the model's depth steps (its silhouette, the end face's rims, the bore) read as a ToF sensor
// reads them: missing or mixed, about half each, whatever their depth.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"

namespace drill_pipe_pose {

/// [m] a range difference between neighbouring pixels of the model's rendered depth that makes
/// a depth step (a ray that misses the model beside one that hits it is one too): the jump that
/// the real board's silhouette measures were taken at (docs/sensor_check.md).
constexpr double kEdgeStepJump = 0.05;

/// The pixels of one camera that the likelihood judges: a rectangle [u0, v0, u1, v1) of its
/// delivered depth image (its border only rendered), and optionally which of them count.
struct EdgeRegion {
  std::array<int, 4> rect{{0, 0, 0, 0}};
  enum Use : uint8_t { kRendered = 1, kJudged = 2 };
  /// Per pixel of rect (row-major), bits of Use: rendered at each pose (else fixed_depth's), and
  /// judged. Empty: every pixel rendered and judged.
  std::vector<uint8_t> mask;
  std::vector<float> fixed_depth;  ///< with a mask: the model's depth at the pixels not rendered
};

/// The region of each camera's depth image that the likelihood judges for an end near
/// T_world_end: the end frame's box |x|, |y| <= radius, z from edges.region_below under the
/// end's top (the box's end face, the pin's nose) to edges.region_above beyond it, grown by
/// `reach` [m] along the axis, projected, a pixel added, cut to the crop. One
/// scan judges every pose on the same pixels. A rect {0, 0, 0, 0}: the camera does not see the
/// end.
std::vector<EdgeRegion> edgeRegions(const ProfileModel& model, double radius,
                                    const Eigen::Isometry3d& T_world_end,
                                    const std::vector<CycleCamera>& cameras,
                                    const EstimatorConfig::Edges& edges, double reach);

/// Masks each region for a scan of the model up to +-`reach` [m] along its axis from
/// T_world_end: a pixel whose rendered depth is the same at either end of the move as in the
/// middle keeps that depth (a joint's cylinders slide along their own surface), and only the
/// pixels whose kind or outcome can change are judged (it or a 4-neighbour changes, or it reads a
/// surface near the model where the model misses it). The others add the same to every pose's
/// likelihood: the scan's best pose is the same without them.
void keepChangingPixels(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                        double reach, const std::vector<CycleCamera>& cameras,
                        const EstimatorConfig::Noise& noise, double margin,
                        std::vector<EdgeRegion>* regions);

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
  /// Per region (camera): the pixels judged, and the two shares (0 where it judged no pixel of
  /// the kind).
  std::vector<int> camera_pixels;
  std::vector<double> camera_step_missing, camera_on_missing;
};

/// The outcomes' probabilities as the pixels of `regions` read them with the model at
/// T_world_end (a pose within a pixel of the truth), with the configured figures (edges.*) as a
/// prior worth edges.prior_pixels pixels: what this sensor does at this end's steps today (a
/// driver's edge filter, the scene's materials), not assumed.
EdgeOutcomes estimateEdgeOutcomes(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                                  const std::vector<CycleCamera>& cameras,
                                  const std::vector<EdgeRegion>& regions,
                                  const EstimatorConfig::Edges& edges,
                                  const EstimatorConfig::Noise& noise, double margin);

/// Negative log-likelihood [nats] of the judged pixels of `regions` (edgeRegions: those away
/// from each region's border) given `model` at T_world_end: the model rendered into each
/// region, each pixel's kind and outcome (EdgeOutcomes) priced by `outcomes`.
double edgeNegLogLikelihood(const ProfileModel& model, const Eigen::Isometry3d& T_world_end,
                            const std::vector<CycleCamera>& cameras,
                            const std::vector<EdgeRegion>& regions,
                            const EdgeOutcomes& outcomes, const EstimatorConfig::Noise& noise,
                            double margin);

}  // namespace drill_pipe_pose
