#pragma once
// The tool-joint models the estimator fits, built once from the configuration (private to the
// estimator's sources).

#include <array>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

/// Per end ([0] box_end, [1] pin_end): the profile model, a search model with a tong 0.3 m longer
/// (a worn joint's taper cannot pull the 1-DoF search), and the camera-facing surface samples of
/// the free-space check (end frame [m]: the joint with free_space.tube_length of tube).
struct EndModels {
  /// Both ends from config.dims.
  explicit EndModels(const EstimatorConfig& config);
  /// The box end from box, the pin end from pin (each end's pipe type).
  EndModels(const EstimatorConfig& config, const ToolJointDimensions& box,
            const ToolJointDimensions& pin);
  std::array<double, kNumEnds> joint_radius{};  ///< [m] tool-joint OD / 2 of each end's model
  std::array<double, kNumEnds> tube_radius{};   ///< [m] tube OD / 2 of each end's model
  std::array<ProfileModel, kNumEnds> models;
  std::array<ProfileModel, kNumEnds> search_models;
  std::array<std::vector<OrientedPoint>, kNumEnds> fs_samples;
};

}  // namespace drill_pipe_pose
