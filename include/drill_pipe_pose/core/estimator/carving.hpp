#pragma once
// Stage "carving": visual-hull fusion of the cameras' cut-out points.

#include <vector>

#include "drill_pipe_pose/core/estimator/cutout.hpp"

namespace drill_pipe_pose {

/// Visual-hull carving of the points of `label` (see EstimatorConfig::Carving).
std::vector<CloudPoint> carve(const std::vector<CloudPoint>& points, EndLabel label,
                              const std::vector<CycleCamera>& cameras,
                              const EstimatorConfig::Carving& config);

}  // namespace drill_pipe_pose
