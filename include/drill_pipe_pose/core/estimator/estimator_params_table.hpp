#pragma once
// The one table of the pose estimator's parameters (param_table.hpp): every EstimatorConfig field
// with its key (the ROS parameter path below the node's namespace, e.g. carving/vote_fraction),
// type, unit, allowed range and one line of documentation. Defaults are the struct's initialisers
// (estimator_config.hpp), which are also the pose_estimator node's defaults. From this table come
// the node's loader, validateConfig's range checks, the tools' --config / --param, and the
// parameter reference (a test checks that docs/parameters.md matches estimatorParamsMarkdown()).
//
// Adding a parameter: a field with its default in estimator_config.hpp, one DPP_PARAM line in
// src/core/estimator/estimator_params_table.cpp, and the code that uses it.

#include <array>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/frame_sync.hpp"
#include "drill_pipe_pose/core/param_table.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"

namespace drill_pipe_pose {

/// What the pose_estimator node reads besides the estimator's configuration. ROS-free, so that
/// tools read the same YAML file as the node.
struct EstimatorNodeConfig {
  std::vector<std::string> cameras;  ///< required: the sensor nodes to fuse
  std::string world_frame = conventions::kDefaultWorldFrame;
  std::array<std::string, kNumEnds> end_frames{{"box_end", "pin_end"}};  ///< TF child frames
  double max_pose_age = 0.2;  ///< [s] an end not seen for longer is reported invalid
  double tf_timeout = 0.0;    ///< [s] wait for TF per lookup (0: only what is buffered)
  double debug_frustum_length = 1.5;  ///< [m] drawn length of the cameras' frustums (debug/models)
  /// Rig file (docs/conventions.md "Rig file") whose per-camera depth_offset / depth_scale
  /// correct each camera's depth; empty: no correction.
  std::string rig;
  FrameSyncConfig sync;
  InputLimits limits;  ///< per-frame size limits (a frame beyond one is dropped)
  EstimatorConfig estimator;
};

/// Every EstimatorConfig field, keyed as the node's parameters are.
const ParamTable<EstimatorConfig>& estimatorParamTable();

/// The node's own rows (cameras, frames, sync/...) followed by estimatorParamTable()'s rows.
const ParamTable<EstimatorNodeConfig>& estimatorNodeParamTable();

/// Sets one estimator parameter from text (`--param key=value`): e.g. applyParam(&c,
/// "carving/vote_fraction", "0.8"). Throws InputError on an unknown key (with the nearest
/// names), a value of the wrong type or out of the key's range (naming key and range). Does not
/// run the cross-field checks: call validateConfig when done.
void applyParam(EstimatorConfig* config, const std::string& key, const std::string& value);

/// Reads the YAML file the node loads (e.g. config/estimator_thesis_lab.yaml: nested maps give
/// the keys, work_zone: {min: [..]} is work_zone/min) into `config`, then validateConfig. The
/// node's own keys (cameras, sync/..., estimatorNodeParamTable()) are checked and skipped; any
/// other key is an error. Throws InputError naming the file and the key.
void loadEstimatorYaml(EstimatorConfig* config, const std::string& path);

/// As loadEstimatorYaml, into the node's whole configuration (validateEstimatorNodeConfig).
void loadEstimatorNodeYaml(EstimatorNodeConfig* config, const std::string& path);

/// Ranges of every row, `cameras` given, and validateConfig. Throws InputError naming the key.
void validateEstimatorNodeConfig(const EstimatorNodeConfig& config);

/// The pose_estimator parameter table of docs/parameters.md (Markdown, one row per key, node defaults).
std::string estimatorParamsMarkdown();

}  // namespace drill_pipe_pose
