#pragma once
// Command-line pieces the simulator tools share (simulate_bag, simulate_calibration,
// render_board).

#include <string>
#include <vector>

#include "cli.hpp"
#include "drill_pipe_pose/sim/sensor_model.hpp"

namespace drill_pipe_pose::tools {

/// A repeatable option whose every value is checked at parse time by applying it to a default
/// sim::SensorEffects with `apply` (which throws InputError with its message when it refuses).
template <typename Apply>
CLI::Option* addSensorEffectsOption(CLI::App& app, const std::string& flag,
                                    std::vector<std::string>* values, const std::string& doc,
                                    const std::string& metavar, Apply apply) {
  return app.add_option(flag, *values, doc)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->expected(1)
      ->option_text(metavar + " ...")
      ->check(throwingCheck(metavar, [apply](const std::string& v) {
        sim::SensorEffects fx;
        apply(&fx, v);
      }));
}

/// A repeatable option naming sensor effects to switch off (sim::switchOffEffect).
inline CLI::Option* addEffectOffOption(CLI::App& app, const std::string& flag,
                                       std::vector<std::string>* names, const std::string& doc) {
  return addSensorEffectsOption(
      app, flag, names, doc, "EFFECT",
      [](sim::SensorEffects* fx, const std::string& v) { sim::switchOffEffect(fx, v); });
}

/// A repeatable option setting one numeric sensor parameter, NAME=VALUE
/// (sim::setEffectParameter).
inline CLI::Option* addSensorParamOption(CLI::App& app, const std::string& flag,
                                         std::vector<std::string>* assignments,
                                         const std::string& doc) {
  return addSensorEffectsOption(
      app, flag, assignments, doc, "NAME=VALUE",
      [](sim::SensorEffects* fx, const std::string& v) { sim::setEffectParameter(fx, v); });
}

}  // namespace drill_pipe_pose::tools
