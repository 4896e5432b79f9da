#pragma once
// EstimatorConfig from ROS parameters (the node's private namespace). Keys mirror the struct:
// method, work_zone/min, work_zone/max, tool_joint/<dimension>, cutout/<field>, carving/<field>,
// axis_fit/<field>, profile_fit/<field>, noise/<field>, covariance/<field>, baseline/<field>.

#include <ros/node_handle.h>

#include <string>

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"

namespace drill_pipe_pose {

/// Reads and validates the configuration; throws InputError naming the parameter.
EstimatorConfig loadEstimatorConfig(const ros::NodeHandle& pnh);

/// One line per setting, for the start-up log.
std::string describeEstimatorConfig(const EstimatorConfig& config);

}  // namespace drill_pipe_pose
