// The rig_simulator node's parameter table (simulator_node_params.hpp): one line per parameter.

#include "drill_pipe_pose/sim/simulator_node_params.hpp"

namespace drill_pipe_pose {

namespace {

using C = RigSimulatorNodeConfig;
#define P(key, field, unit, range, doc) DPP_PARAM(C, key, field, unit, range, doc)

ParamTable<C> makeTable() {
  const auto same = [](const std::string& s) { return s; };
  return {
      P("rig", rig, "", anyValue(), "rig file; empty: the package's config/rigs/thesis_lab.yaml"),
      P("scene", scene, "", anyValue(),
        "(required) scene file, e.g. $(find drill_pipe_pose)/config/scenes/thesis_vertical.yaml"),
      paramEnum<C>("profile",
                   {"ideal", "kinect_v2_calibrated", "kinect_v2_field", "kinect_v2_uncalibrated"},
                   "sensor profile (config/sensors)",
                   [](auto& c) -> auto& { return c.options.profile; }, same, same),
      P("seed", options.seed, "", between(0, 4294967295.0), "every random stream derives from it"),
      P("simulated_detection", options.simulated_detection, "", anyValue(),
        "publish <cam>/sensor_frame with simulated boxes"),
      P("color", options.color, "", anyValue(),
        "publish kinect2_bridge-style colour + depth topics too (for a real detector)"),
      P("crop", crop, "", anyValue(), "crop SensorFrame depth to the boxes"),
      P("rate", rate, "", atLeast(1e-3), "simulation seconds per wall second"),
      P("publish_clock", publish_clock, "", anyValue(),
        "publish /clock from simulation time (use_sim_time); false: stamp with wall time"),
      P("duration", duration, "s", atLeast(0), "simulated time, then stop; 0: forever"),
  };
}
#undef P

}  // namespace

const ParamTable<RigSimulatorNodeConfig>& rigSimulatorParamTable() {
  static const ParamTable<RigSimulatorNodeConfig> table = makeTable();
  return table;
}

std::string rigSimulatorParamsMarkdown() {
  return paramTableMarkdown(rigSimulatorParamTable());
}

}  // namespace drill_pipe_pose
