#pragma once
// Free-space evidence: the depth pixels on which a model pose claims a surface that the cameras
// saw through.

#include <Eigen/Geometry>
#include <vector>

#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

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


}  // namespace drill_pipe_pose
