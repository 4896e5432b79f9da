#pragma once
// The rig_simulator node's parameter table (core/param_table.hpp): what the node reads, with
// defaults in the struct below (and in sim::SimulatorOptions). The node's loader and the
// rig_simulator table of docs/parameters.md (checked by a test) come from it.

#include <string>

#include "drill_pipe_pose/core/param_table.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

namespace drill_pipe_pose {

struct RigSimulatorNodeConfig {
  std::string rig;    ///< rig file; "": the package's config/rigs/thesis_lab.yaml
  std::string scene;  ///< required: scene file
  /// profile, seed, simulated_detection, color (sensor_config_dir and the stamps: the node's).
  sim::SimulatorOptions options;
  bool crop = false;           ///< crop SensorFrame depth to the boxes
  double rate = 1.0;           ///< simulation seconds per wall second
  bool publish_clock = false;  ///< publish /clock (use_sim_time) instead of wall stamps
  double duration = 0.0;       ///< [s] of simulation; 0: forever
};

const ParamTable<RigSimulatorNodeConfig>& rigSimulatorParamTable();

/// The rig_simulator parameter table of docs/parameters.md (Markdown).
std::string rigSimulatorParamsMarkdown();

}  // namespace drill_pipe_pose
