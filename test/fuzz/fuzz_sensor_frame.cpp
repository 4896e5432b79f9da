// Fuzz harness: the SensorFrame path of the central node, from the message to the estimator.
//
// What a sensor node sends is the least trusted input of the system: another computer, another
// driver, maybe a truncated bag. This harness builds up to three drill_pipe_pose/SensorFrame
// messages from the fuzz bytes (sensor_frame_input.hpp: any sizes, steps, encodings, rois,
// NaN / inf / zero intrinsics, boxes outside the image or inverted, empty or huge box lists,
// unknown labels, mismatched frame ids, declared 1x1 or 20000x20000 depth images with short
// data) and runs them through the code the pose_estimator node runs on each frame:
//   1. fromMsg(SensorFrameConstPtr) (src/ros/conversions.cpp): conversion and validation; it
//      throws InputError for a bad frame (documented), then toMsg back (the bag/bench path);
//   2. cropDepthToBoxes (core/depth_crop.hpp, the sensor node's bandwidth saver) on a frame
//      that converted; InputError documented;
//   3. the estimator's input assembly and cycle: PoseEstimator (default EstimatorConfig)
//      process() with a CameraInput per converted frame (with the fuzzed TF transforms and depth
//      correction), once or twice (the second cycle continues the first one's tracks). process()
//      documents that it never throws on bad data: a bad camera lands in camera_errors.
// Anything else - a sanitizer report, a crash, another exception - is a bug.

#include <boost/make_shared.hpp>
#include <cstddef>
#include <cstdint>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "sensor_frame_input.hpp"

using namespace drill_pipe_pose;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // One estimator for the process, reset per input: every input starts from a new estimator's
  // state (a failure reproduces from its input alone) without rebuilding the models each time.
  static PoseEstimator estimator{EstimatorConfig()};
  estimator.reset();

  fuzz::FuzzSensorInput in = fuzz::decodeSensorInput(data, size);
  std::vector<CameraInput> inputs;
  for (fuzz::FuzzCamera& cam : in.cameras) {
    const auto msg = boost::make_shared<SensorFrame>(std::move(cam.msg));
    CameraInput ci;
    try {
      ci.frame = fromMsg(SensorFrameConstPtr(msg));
    } catch (const InputError&) {
      // A bad frame is documented to be rejected at the door; the estimator below must also
      // reject it on its own (a frame can reach it unconverted from a bag): pass it on raw.
      try {
        ci.frame = fuzz::rawFrame(*msg);
      } catch (const InputError&) {
        continue;  // no DepthImage to pass on (unsupported encoding)
      }
      ci.T_world_depth = cam.T_world_depth;
      ci.T_color_depth = cam.T_color_depth;
      ci.depth_correction = cam.correction;
      inputs.push_back(std::move(ci));
      continue;
    }
    (void)toMsg(ci.frame);
    try {
      (void)cropDepthToBoxes(ci.frame, cam.T_color_depth);
    } catch (const InputError&) {
    }
    ci.T_world_depth = cam.T_world_depth;
    ci.T_color_depth = cam.T_color_depth;
    ci.depth_correction = cam.correction;
    inputs.push_back(std::move(ci));
  }

  estimator.process(inputs);  // documented: never throws on bad data
  if (in.second_cycle) {
    for (CameraInput& ci : inputs) ci.frame.stamp_ns += 33333333;  // the next 30 Hz cycle
    estimator.process(inputs);
  }
  return 0;
}
