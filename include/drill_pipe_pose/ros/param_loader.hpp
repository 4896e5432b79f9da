#pragma once
// Loads a parameter table (core/param_table.hpp) from the ROS parameter server: every row whose
// key is set under the node handle's namespace is read as the row's type and checked against its
// range. A missing key keeps the configuration's default; a wrong type or a value out of range is
// an InputError naming the resolved parameter and the allowed range, e.g.
// "parameter /drill_pipe_pose/carving/min_cameras = 0: must be >= 1".

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "drill_pipe_pose/core/param_table.hpp"

namespace drill_pipe_pose {

/// The value of `key` on the parameter server as the row's type; throws InputError naming the
/// resolved key and the expected type (the value is not range-checked here).
ParamValue readRosParam(const ros::NodeHandle& nh, const ParamInfo& info);

/// Keys under the namespace of `nh` that are not in `known` (nor below a known key): the caller
/// warns about them (likely misspelt).
std::vector<std::string> unknownRosParams(const ros::NodeHandle& nh,
                                          const std::vector<std::string>& known);

/// Reads every row of `table` that is set; throws InputError naming the parameter.
template <class Config>
void loadRosParams(const ros::NodeHandle& nh, const ParamTable<Config>& table, Config* config) {
  for (const auto& s : table) {
    if (!nh.hasParam(s.info.name)) continue;
    ParamInfo resolved = s.info;
    resolved.name = nh.resolveName(s.info.name);
    const ParamValue v = readRosParam(nh, s.info);
    checkParamValue(resolved, v, "");
    s.set(*config, v);
  }
}

}  // namespace drill_pipe_pose
