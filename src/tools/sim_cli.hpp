#pragma once
// Command-line pieces the simulator tools share (simulate_bag, simulate_calibration,
// render_board).

#include <string>
#include <vector>

#include "cli.hpp"
#include "drill_pipe_pose/sim/sensor_model.hpp"

namespace drill_pipe_pose::tools {

/// A repeatable option naming sensor effects to switch off; a name sim::switchOffEffect does not
/// know is refused at parse time with its message.
inline CLI::Option* addEffectOffOption(CLI::App& app, const std::string& flag,
                                       std::vector<std::string>* names, const std::string& doc) {
  return app.add_option(flag, *names, doc)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->expected(1)
      ->option_text("EFFECT ...")
      ->check(throwingCheck("EFFECT", [](const std::string& v) {
        sim::SensorEffects fx;
        sim::switchOffEffect(&fx, v);
      }));
}

/// A repeatable option setting one numeric sensor parameter, NAME=VALUE; an assignment
/// sim::setEffectParameter refuses is refused at parse time with its message.
inline CLI::Option* addSensorParamOption(CLI::App& app, const std::string& flag,
                                         std::vector<std::string>* assignments,
                                         const std::string& doc) {
  return app.add_option(flag, *assignments, doc)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->expected(1)
      ->option_text("NAME=VALUE ...")
      ->check(throwingCheck("NAME=VALUE", [](const std::string& v) {
        sim::SensorEffects fx;
        sim::setEffectParameter(&fx, v);
      }));
}

}  // namespace drill_pipe_pose::tools
