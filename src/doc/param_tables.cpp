// param_tables: the parameter reference (docs/parameters.md), generated from the nodes'
// parameter tables (core/estimator/estimator_params_table.hpp, core/detector/detector_node_params.hpp,
// sim/simulator_node_params.hpp).
//   param_tables                     print the three tables (Markdown)
//   param_tables --check docs/parameters.md   exit 1 when its generated sections differ
//   param_tables --update docs/parameters.md  rewrite its generated sections
#include <CLI/CLI.hpp>

#include <fstream>
#include <iostream>
#include <sstream>

#include "drill_pipe_pose/core/detector/detector_node_params.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"
#include "drill_pipe_pose/sim/simulator_node_params.hpp"

namespace {

using namespace drill_pipe_pose;

const std::vector<std::pair<std::string, std::string>>& sections() {
  static const std::vector<std::pair<std::string, std::string>> s = {
      {"pose_estimator parameters", estimatorParamsMarkdown()},
      {"pipe_detector parameters", pipeDetectorParamsMarkdown()},
      {"rig_simulator parameters", rigSimulatorParamsMarkdown()},
  };
  return s;
}

std::string readFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail("cannot open '", path, "'");
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The parameter reference's tables (docs/parameters.md), generated from the nodes' "
               "parameter tables."};
  std::string check, update;
  app.add_option("--check", check, "page to compare (exit 1 when it differs)");
  app.add_option("--update", update, "page whose generated sections are rewritten");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help: 0; a bad option: 2
  }
  try {
    if (check.empty() && update.empty()) {
      for (const auto& [name, text] : sections())
        std::cout << "### " << name << "\n\n" << text << "\n";
      return 0;
    }
    const std::string path = check.empty() ? update : check;
    const std::string readme = readFile(path);
    std::string out = readme;
    for (const auto& [name, text] : sections()) out = replaceGeneratedSection(out, name, text);
    if (!check.empty()) {
      if (out == readme) return 0;
      std::cerr << path << ": parameter tables differ from the code; run param_tables --update "
                << path << "\n";
      return 1;
    }
    std::ofstream(path) << out;
    return 0;
  } catch (const InputError& e) {
    std::cerr << "param_tables: " << e.what() << "\n";
    return 2;
  }
}
