// Fuzz harness: the rig calibration loader (core/rig_calibration.hpp) on mutated YAML.
//
// The rig file is written by hand or by calibrate_rig and read by the simulator, rig_tf_publisher
// (static TF of the whole rig), rig_info and the pose estimator (depth corrections): a typo in it
// must end in an InputError naming the file, the camera and the field, never in a crash or in an
// exception of yaml-cpp escaping to the node's main(). Seeds: config/rigs/*.yaml.
// Checked beyond "no crash": a file that loads round-trips (documented): its
// rigCalibrationToYaml text loads again, to the same cameras, poses and depth calibrations.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"

using namespace drill_pipe_pose;

namespace {
[[noreturn]] void violated(const std::string& what, const std::string& text) {
  std::fprintf(stderr, "fuzz_rig_yaml: %s\n--- text written by rigCalibrationToYaml:\n%s\n",
               what.c_str(), text.c_str());
  std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  RigCalibration rig;
  try {
    rig = parseRigCalibration(text, "fuzz_rig.yaml");
  } catch (const InputError&) {
    return 0;  // documented: a bad file is an InputError naming the field
  }
  const std::string again = rigCalibrationToYaml(rig);
  RigCalibration back;
  try {
    back = parseRigCalibration(again, "round_trip.yaml");
  } catch (const InputError& e) {
    violated(std::string("a loaded rig does not load again after rigCalibrationToYaml: ") +
                 e.what(),
             again);
  }
  if (back.world_frame != rig.world_frame || back.cameras.size() != rig.cameras.size())
    violated("round trip changed world_frame or the camera count", again);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const CameraCalibration &a = rig.cameras[i], &b = back.cameras[i];
    if (a.name != b.name || a.sensor != b.sensor || a.depth_offset != b.depth_offset ||
        a.depth_scale != b.depth_scale ||
        !a.T_world_link.matrix().isApprox(b.T_world_link.matrix(), 1e-9))
      violated("round trip changed camera '" + a.name + "'", again);
  }
  return 0;
}
