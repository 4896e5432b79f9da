#pragma once
// EstimatorConfig / EstimatorNodeConfig from ROS parameters (the node's private namespace), through
// the parameter table (core/estimator/estimator_params_table.hpp): every row is loadable, keys are
// the rows' names (carving/vote_fraction, work_zone/min, ...).

#include <ros/node_handle.h>

#include <string>

#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"

namespace drill_pipe_pose {

/// Reads and validates the configuration; throws InputError naming the parameter.
EstimatorConfig loadEstimatorConfig(const ros::NodeHandle& pnh);

/// The node's whole configuration (cameras, frames, sync/..., and the estimator's), validated;
/// throws InputError naming the parameter; warns about keys in the namespace that no row has.
EstimatorNodeConfig loadEstimatorNodeConfig(const ros::NodeHandle& pnh);

/// Sets config->pipe_catalog to the package's config/pipe_catalog.yaml when it is empty.
void defaultPipeCatalog(EstimatorConfig* config);

/// One line per setting, for the start-up log.
std::string describeEstimatorConfig(const EstimatorConfig& config);

}  // namespace drill_pipe_pose
