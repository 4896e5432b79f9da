// Fuzz harness: the per-frame half of the SensorFrame path, from the message to the cut-out
// points, without the fit.
//
// fuzz_sensor_frame runs the whole estimator cycle on every input, which makes it the slowest
// harness by far (about 20 inputs/s sanitized): too slow for 10^6 inputs. This harness takes the
// same inputs (its corpus and regressions are sensor_frame's: sensor_frame_input.hpp) through
// the code that runs on every frame before the fit, hundreds of times faster:
//   1. fromMsg(SensorFrameConstPtr) (src/ros/conversions.cpp), InputError documented for a bad
//      frame, then toMsg back;
//   2. cropDepthToBoxes (core/depth_crop.hpp), InputError documented;
//   3. makeCycleCamera (core/estimator/cutout.hpp: the estimator's input validation, with the
//      fuzzed TF transforms and depth correction), InputError documented; for a frame that
//      fromMsg refused too, since a frame can reach the estimator unconverted from a bag;
//   4. cutOutCamera with the default EstimatorConfig and a finite work zone.
// Checked besides the sanitizers: every cut-out point is finite, inside the work zone, with a
// positive finite sigma and its camera's index. Anything else - a sanitizer report, a crash,
// another exception, a broken property - is a bug.

#include <boost/make_shared.hpp>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "sensor_frame_input.hpp"

using namespace drill_pipe_pose;

namespace {

void fail(const char* what, uint16_t camera) {
  std::fprintf(stderr, "sensor_frame_cutout: camera %u: %s\n", static_cast<unsigned>(camera),
               what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const EstimatorConfig config = [] {
    EstimatorConfig c;
    c.work_zone.min = Eigen::Vector3d(-20.0, -20.0, -5.0);  // a finite zone: its test is checked
    c.work_zone.max = Eigen::Vector3d(20.0, 20.0, 20.0);
    return c;
  }();

  fuzz::FuzzSensorInput in = fuzz::decodeSensorInput(data, size);
  std::array<std::vector<CloudPoint>, kNumEnds> out;
  uint16_t index = 0;
  for (fuzz::FuzzCamera& cam : in.cameras) {
    const auto msg = boost::make_shared<SensorFrame>(std::move(cam.msg));
    SensorFrameData frame;
    try {
      frame = fromMsg(SensorFrameConstPtr(msg));
      (void)toMsg(frame);
      try {
        (void)cropDepthToBoxes(frame, cam.T_color_depth);
      } catch (const InputError&) {
      }
    } catch (const InputError&) {
      try {
        frame = fuzz::rawFrame(*msg);
      } catch (const InputError&) {
        continue;  // no DepthImage to pass on (unsupported encoding)
      }
    }
    CycleCamera cc;
    try {
      cc = makeCycleCamera(frame, cam.T_world_depth, cam.T_color_depth, 0.0f, cam.correction);
    } catch (const InputError&) {
      continue;
    }
    for (auto& pts : out) pts.clear();
    cutOutCamera(cc, index, config, &out);
    const Eigen::Vector3f lo = config.work_zone.min.cast<float>();
    const Eigen::Vector3f hi = config.work_zone.max.cast<float>();
    for (const auto& pts : out) {
      for (const CloudPoint& p : pts) {
        if (!p.p_world.allFinite()) fail("a cut-out point is not finite", index);
        if ((p.p_world.array() < lo.array()).any() || (p.p_world.array() > hi.array()).any())
          fail("a cut-out point lies outside the work zone", index);
        if (!(std::isfinite(p.sigma) && p.sigma > 0.0f))
          fail("a cut-out point's sigma is not positive and finite", index);
        if (p.camera != index) fail("a cut-out point carries another camera's index", index);
      }
    }
    ++index;
  }
  return 0;
}
