// rostest (pipe_detector.test): rig_simulator publishes kinect2_bridge-style topics for the thesis
// rig; two pipe_detector nodes for cam1 (full depth, and depth cropped to the boxes) publish
// SensorFrames. Checks: stamps are the colour images' capture stamps, frame ids and labels follow
// the conventions, the boxes match the ground-truth silhouettes (IoU >= 0.5), and the cropped
// frames carry the same boxes and exactly the full depth's pixels inside their roi.
#include <drill_pipe_pose/SensorFrame.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>

#include <cstring>
#include <map>
#include <mutex>
#include <set>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/detector/yolo_decoding.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

using namespace drill_pipe_pose;

namespace {

const std::string kSource = DRILL_PIPE_POSE_SOURCE_DIR;

detector::ScoredBox toBox(float x0, float y0, float x1, float y1) {
  detector::ScoredBox b;
  b.x_min = x0;
  b.y_min = y0;
  b.x_max = x1;
  b.y_max = y1;
  return b;
}

}  // namespace

TEST(PipeDetectorNode, SensorFramesFromSimulatedCameraTopics) {
  ros::NodeHandle nh;
  std::mutex m;
  std::set<uint64_t> color_stamps;
  std::map<uint64_t, SensorFrameConstPtr> full, cropped;
  auto s1 = nh.subscribe<sensor_msgs::Image>("cam1/qhd/image_color_rect", 20,
                                             [&](const sensor_msgs::ImageConstPtr& msg) {
                                               std::lock_guard<std::mutex> l(m);
                                               color_stamps.insert(msg->header.stamp.toNSec());
                                             });
  auto s2 = nh.subscribe<SensorFrame>("cam1/sensor_frame", 20, [&](const SensorFrameConstPtr& msg) {
    std::lock_guard<std::mutex> l(m);
    full[msg->header.stamp.toNSec()] = msg;
  });
  auto s3 = nh.subscribe<SensorFrame>("cam1/sensor_frame_cropped", 20,
                                      [&](const SensorFrameConstPtr& msg) {
                                        std::lock_guard<std::mutex> l(m);
                                        cropped[msg->header.stamp.toNSec()] = msg;
                                      });
  ros::AsyncSpinner spinner(2);
  spinner.start();
  auto common = [&] {
    size_t n = 0;
    for (const auto& kv : full) n += cropped.count(kv.first);
    return n;
  };
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(120.0);
  while (ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> l(m);
      if (full.size() >= 3 && common() >= 2) break;
    }
    ros::WallDuration(0.2).sleep();
  }
  // The colour images and the SensorFrames come on two connections: a frame's colour image may
  // reach this test after the frame itself. Let them arrive before the check.
  ros::WallDuration(1.0).sleep();
  spinner.stop();
  std::lock_guard<std::mutex> l(m);
  ASSERT_GE(full.size(), 3u) << "too few SensorFrames on /cam1/sensor_frame";
  ASSERT_GE(common(), 2u) << "too few cropped SensorFrames with the stamps of full ones";

  // Ground truth: the exact visible silhouettes of the ends in cam1 (static scene).
  sim::SimulatorOptions opt;
  opt.color = false;
  opt.sensor_config_dir = kSource + "/config/sensors";
  opt.detector.edge_jitter_px = 0;
  opt.detector.miss_probability = 0;
  opt.detector.swap_probability = 0;
  opt.detector.duplicate_probability = 0;
  opt.detector.false_positive_probability = 0;
  const auto sim = sim::loadScenario(kSource + "/config/rigs/thesis_lab.yaml",
                                     kSource + "/config/scenes/thesis_vertical.yaml", opt);
  ASSERT_EQ(sim->cameraName(0), "cam1");
  const std::vector<DetectionBox> truth = sim->render(0, 0.0, 0).sensor_frame.boxes;
  ASSERT_EQ(truth.size(), 2u);

  // A SensorFrame stamped before the first colour image this test received was made from an
  // image published before the test's colour subscription connected: not checked against them.
  ASSERT_FALSE(color_stamps.empty()) << "no colour image on /cam1/qhd/image_color_rect";
  size_t stamps_checked = 0;
  for (const auto& [stamp, f] : full) {
    if (stamp >= *color_stamps.begin()) {
      ++stamps_checked;
      EXPECT_TRUE(color_stamps.count(stamp))
          << "SensorFrame stamp " << stamp << " is no colour image's capture stamp";
    }
    EXPECT_EQ(f->camera, "cam1");
    EXPECT_EQ(f->header.frame_id, conventions::colorOpticalFrame("cam1"));
    EXPECT_EQ(f->color_info.header.stamp, f->header.stamp);
    EXPECT_EQ(f->depth.header.frame_id, conventions::depthOpticalFrame("cam1"));
    EXPECT_EQ(f->depth_info.roi.width, 0u);  // full depth
    EXPECT_EQ(f->depth.width, f->depth_info.width);
    EXPECT_LE(f->boxes.size(), 2u);  // max one box per class
    for (const auto& b : f->boxes)
      EXPECT_TRUE(b.label == PipeBox::BOX_END || b.label == PipeBox::PIN_END) << b.label;
    for (const DetectionBox& t : truth) {
      float best = 0;
      for (const auto& b : f->boxes)
        if (b.label == labelName(t.label))
          best = std::max(best, detector::iou(toBox(b.x_min, b.y_min, b.x_max, b.y_max),
                                              toBox(t.x_min, t.y_min, t.x_max, t.y_max)));
      EXPECT_GE(best, 0.5f) << labelName(t.label) << " at stamp " << stamp;
    }
  }
  EXPECT_GE(stamps_checked, 2u) << "too few SensorFrames after the first colour image";

  for (const auto& [stamp, c] : cropped) {
    const auto it = full.find(stamp);
    if (it == full.end()) continue;
    const SensorFrame& f = *it->second;
    ASSERT_EQ(c->boxes.size(), f.boxes.size());
    for (size_t i = 0; i < f.boxes.size(); ++i) {
      EXPECT_EQ(c->boxes[i].label, f.boxes[i].label);
      EXPECT_FLOAT_EQ(c->boxes[i].x_min, f.boxes[i].x_min);
      EXPECT_FLOAT_EQ(c->boxes[i].y_max, f.boxes[i].y_max);
      EXPECT_FLOAT_EQ(c->boxes[i].confidence, f.boxes[i].confidence);
    }
    const auto& roi = c->depth_info.roi;
    EXPECT_GT(roi.width, 0u);
    if (f.boxes.empty()) continue;  // no boxes: a single invalid pixel is sent (core depth_crop)
    EXPECT_LT(roi.width * roi.height, f.depth.width * f.depth.height / 4);  // a real saving
    ASSERT_EQ(c->depth.width, roi.width);
    ASSERT_EQ(c->depth.height, roi.height);
    ASSERT_EQ(c->depth.encoding, f.depth.encoding);
    const size_t bpp = f.depth.step / f.depth.width;
    for (uint32_t v = 0; v < roi.height; ++v)
      ASSERT_EQ(0,
                std::memcmp(&c->depth.data[v * c->depth.step],
                            &f.depth.data[(v + roi.y_offset) * f.depth.step + roi.x_offset * bpp],
                            roi.width * bpp))
          << "cropped depth row " << v << " differs from the full depth";
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_pipe_detector_node");
  return RUN_ALL_TESTS();
}
