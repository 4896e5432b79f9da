// The sensor node's frame assembly (core/detector/frame_assembly.hpp), which the pipe_detector
// node, detect_bag and simulate_bag --detector-model share: a rendered colour + depth frame in, a
// SensorFrame with the shipped model's boxes out (deterministic: a fixed simulator seed, printed
// on failure), its depth cropped as cropDepthToBoxes crops it, and bad input named by its source.
#include <gtest/gtest.h>

#include <filesystem>

#include "drill_pipe_pose/core/detector/frame_assembly.hpp"
#include "drill_pipe_pose/core/detector/yolo_decoding.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::detector;

namespace {

const std::string kSource = DRILL_PIPE_POSE_SOURCE_DIR;
constexpr uint64_t kSeed = 4243;  // a simulator seed no training, tuning or bench run uses

/// One rendered frame of camera 0 of thesis_vertical: colour, depth, and the true boxes (the
/// simulated detector without noise).
struct Rendered {
  std::unique_ptr<sim::RigSimulator> sim;
  sim::RigSimulator::Frame frame;
};

Rendered render() {
  sim::SimulatorOptions opt;
  opt.profile = "kinect_v2_calibrated";
  opt.seed = kSeed;
  opt.color = true;
  opt.sensor_config_dir = kSource + "/config/sensors";
  opt.detector.edge_jitter_px = 0;
  opt.detector.miss_probability = 0;
  opt.detector.swap_probability = 0;
  opt.detector.duplicate_probability = 0;
  opt.detector.false_positive_probability = 0;
  Rendered r;
  r.sim = sim::loadScenario(kSource + "/config/rigs/thesis_lab.yaml",
                            kSource + "/config/scenes/thesis_vertical.yaml", opt);
  r.frame = r.sim->render(0, 0.0, 0);
  return r;
}

ColorPixels pixels(const sim::RigSimulator::Frame& f) {
  ColorPixels p;
  p.encoding = "bgr8";
  p.width = f.color_width;
  p.height = f.color_height;
  p.step = 3 * f.color_width;
  p.data = f.bgr.data();
  p.size = f.bgr.size();
  return p;
}

YoloDetector& shippedDetector() {
  static YoloDetector det([] {
    DetectorConfig c;
    c.model = kSource + "/models/detector/pipe_yolo.onnx";
    return c;
  }());
  return det;
}

float boxIou(const DetectionBox& a, const DetectionBox& b) {
  ScoredBox x, y;
  x.x_min = a.x_min, x.y_min = a.y_min, x.x_max = a.x_max, x.y_max = a.y_max;
  y.x_min = b.x_min, y.y_min = b.y_min, y.x_max = b.x_max, y.y_max = b.y_max;
  return iou(x, y);
}

}  // namespace

TEST(FrameAssembly, RenderedFrameGetsTheModelsBoxesAndTheNodesCrop) {
  SCOPED_TRACE("thesis_vertical, camera 0, t = 0, simulator seed " + std::to_string(kSeed));
  ASSERT_TRUE(std::filesystem::exists(kSource + "/models/detector/pipe_yolo.onnx"));
  const Rendered r = render();
  const SensorFrameData& truth = r.frame.sensor_frame;
  ASSERT_GE(truth.boxes.size(), 1u);
  SensorFrameData in = truth;
  in.boxes.clear();
  const Eigen::Isometry3d T = r.sim->T_link_depth(0);
  FrameAssemblyOptions o;
  const FrameSources src = kinectSources(truth.camera);

  // Full depth: the input frame with the model's boxes; every true end found with IoU >= 0.5.
  const SensorFrameData full = assembleSensorFrame(shippedDetector(), in, pixels(r.frame), &T, o,
                                                   src);
  EXPECT_EQ(full.camera, truth.camera);
  EXPECT_EQ(full.stamp_ns, truth.stamp_ns);
  EXPECT_EQ(full.depth_stamp_ns, truth.depth_stamp_ns);
  EXPECT_EQ(full.frame_id, truth.frame_id);
  EXPECT_EQ(full.depth_frame_id, truth.depth_frame_id);
  EXPECT_TRUE(full.depth_info.roi.isFull());
  for (const DetectionBox& gt : truth.boxes) {
    float best = 0;
    for (const DetectionBox& d : full.boxes)
      if (d.label == gt.label) best = std::max(best, boxIou(d, gt));
    EXPECT_GE(best, 0.5f) << labelName(gt.label) << " truth [" << gt.x_min << ", " << gt.y_min
                          << ", " << gt.x_max << ", " << gt.y_max << "]";
  }

  // crop_depth: the same boxes, the depth cropped exactly as cropDepthToBoxes crops it.
  o.crop_depth = true;
  const SensorFrameData cropped =
      assembleSensorFrame(shippedDetector(), in, pixels(r.frame), &T, o, src);
  ASSERT_EQ(cropped.boxes.size(), full.boxes.size());
  for (size_t i = 0; i < full.boxes.size(); ++i) {
    EXPECT_EQ(cropped.boxes[i].label, full.boxes[i].label);
    EXPECT_EQ(cropped.boxes[i].x_min, full.boxes[i].x_min);
    EXPECT_EQ(cropped.boxes[i].y_max, full.boxes[i].y_max);
  }
  const SensorFrameData expected = cropDepthToBoxes(full, T, o.crop);
  EXPECT_FALSE(cropped.depth_info.roi.isFull());
  EXPECT_EQ(cropped.depth_info.roi.x_offset, expected.depth_info.roi.x_offset);
  EXPECT_EQ(cropped.depth_info.roi.y_offset, expected.depth_info.roi.y_offset);
  EXPECT_EQ(cropped.depth_info.roi.width, expected.depth_info.roi.width);
  EXPECT_EQ(cropped.depth_info.roi.height, expected.depth_info.roi.height);
  EXPECT_EQ(cropped.depth.width, expected.depth.width);
  EXPECT_EQ(cropped.depth.height, expected.depth.height);

  // No colour <- depth transform (the node before TF arrives): the depth stays full.
  const SensorFrameData no_tf =
      assembleSensorFrame(shippedDetector(), in, pixels(r.frame), nullptr, o, src);
  EXPECT_TRUE(no_tf.depth_info.roi.isFull());
  EXPECT_EQ(no_tf.boxes.size(), full.boxes.size());
}

TEST(FrameAssembly, BadInputNamesItsSource) {
  SCOPED_TRACE("simulator seed " + std::to_string(kSeed));
  const Rendered r = render();
  SensorFrameData in = r.frame.sensor_frame;
  in.boxes.clear();
  const FrameSources src = kinectSources(in.camera);
  const FrameAssemblyOptions o;
  auto expectError = [&](const SensorFrameData& f, const ColorPixels& p,
                         const std::vector<std::string>& parts) {
    try {
      assembleSensorFrame(shippedDetector(), f, p, nullptr, o, src);
      ADD_FAILURE() << "no InputError thrown";
    } catch (const InputError& e) {
      for (const auto& part : parts)
        EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
            << "message '" << e.what() << "' lacks '" << part << "'";
    }
  };
  ColorPixels small = pixels(r.frame);
  small.height -= 4;  // the image no longer has its CameraInfo's size
  expectError(in, small, {src.color, src.color_info, "says"});
  SensorFrameData other_info = in;
  other_info.color_info.frame_id = "elsewhere";
  expectError(other_info, pixels(r.frame), {src.color_info, "elsewhere"});
  SensorFrameData other_camera = in;
  other_camera.depth_frame_id = "camX_ir_optical_frame";
  other_camera.depth_info.frame_id = other_camera.depth_frame_id;
  expectError(other_camera, pixels(r.frame), {src.depth, "camX_ir_optical_frame"});
  ColorPixels bad_encoding = pixels(r.frame);
  bad_encoding.encoding = "yuv422";
  expectError(in, bad_encoding, {src.color, "yuv422"});
  EXPECT_EQ(src.color, "/" + in.camera + "/qhd/image_color_rect");
}
