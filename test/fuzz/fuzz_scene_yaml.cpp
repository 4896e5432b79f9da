// Fuzz harness: the simulator's scene loader (sim/scene_config.hpp) on mutated YAML.
//
// Scene files are the test bench's input (every figure of docs/results.md comes from one) and
// are edited by hand; the loader type-checks every key and must answer a bad file with an
// InputError naming the file and the key path, never with a crash, a yaml-cpp exception or
// undefined behaviour (NaN poses, huge counts converted to int). A scene's `pipe_type:` loads
// the package's pipe catalogue (config/pipe_catalog.yaml, beside config/scenes/), as for a real
// scene file. Seeds: config/scenes/*.yaml.

#include <cstddef>
#include <cstdint>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/sim/scene_config.hpp"

using namespace drill_pipe_pose;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // Named as a file in config/scenes/, so that pipe_type finds the package's catalogue.
  static const std::string source =
      std::string(DRILL_PIPE_POSE_SOURCE_DIR) + "/config/scenes/fuzz_input.yaml";
  try {
    (void)sim::parseSceneConfig(text, source);
  } catch (const InputError&) {
    // documented: InputError names the file, the key and what was expected
  }
  return 0;
}
