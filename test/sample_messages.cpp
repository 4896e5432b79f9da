#include "sample_messages.hpp"

#include <ros/serialization.h>

#include <cstring>
#include <random>

namespace drill_pipe_pose_test {

drill_pipe_pose::SensorFrame sampleSensorFrame(const std::string& camera, unsigned seed,
                                               const std::string& encoding) {
  std::mt19937 rng(seed);
  drill_pipe_pose::SensorFrame f;
  f.header.stamp.fromNSec(1700000000123456789ull + seed);
  f.header.frame_id = camera + "_rgb_optical_frame";
  f.camera = camera;

  f.color_info.header = f.header;
  f.color_info.width = 960;
  f.color_info.height = 540;
  f.color_info.distortion_model = "plumb_bob";
  f.color_info.D = {0, 0, 0, 0, 0};
  f.color_info.K = {540.7, 0, 479.75, 0, 540.7, 269.75, 0, 0, 1};
  f.color_info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  f.color_info.P = {540.7, 0, 479.75, 0, 0, 540.7, 269.75, 0, 0, 0, 1, 0};

  f.depth_info = f.color_info;
  f.depth_info.header.frame_id = camera + "_ir_optical_frame";
  f.depth_info.header.stamp.fromNSec(f.header.stamp.toNSec() - 1000000);
  f.depth_info.width = 512;
  f.depth_info.height = 424;
  f.depth_info.K = {365.4, 0, 260.9, 0, 365.4, 205.6, 0, 0, 1};
  f.depth_info.P = {365.4, 0, 260.9, 0, 0, 365.4, 205.6, 0, 0, 0, 1, 0};
  f.depth_info.roi.x_offset = 200;
  f.depth_info.roi.y_offset = 100;
  f.depth_info.roi.width = 37;
  f.depth_info.roi.height = 61;

  f.depth.header = f.depth_info.header;
  f.depth.width = f.depth_info.roi.width;
  f.depth.height = f.depth_info.roi.height;
  f.depth.encoding = encoding;
  f.depth.is_bigendian = 0;
  const size_t bpp = encoding == "32FC1" ? 4 : 2;
  f.depth.step = static_cast<uint32_t>(f.depth.width * bpp);
  f.depth.data.resize(f.depth.step * f.depth.height);
  std::uniform_int_distribution<int> mm(0, 8000);
  for (size_t i = 0; i < size_t{f.depth.width} * f.depth.height; ++i) {
    const int d = mm(rng);
    if (bpp == 2) {
      const uint16_t v = static_cast<uint16_t>(d);
      std::memcpy(&f.depth.data[2 * i], &v, 2);
    } else {
      const float v = d * 0.001f;
      std::memcpy(&f.depth.data[4 * i], &v, 4);
    }
  }

  drill_pipe_pose::PipeBox b;
  b.label = "box_end";
  b.confidence = 0.93f;
  b.x_min = 401.5f;
  b.y_min = 220.25f;
  b.x_max = 420.0f;
  b.y_max = 260.0f;
  f.boxes.push_back(b);
  b.label = "pin_end";
  b.confidence = 0.61f;
  b.x_min = 600.0f;
  b.y_min = 100.0f;
  b.x_max = 615.5f;
  b.y_max = 131.0f;
  f.boxes.push_back(b);
  return f;
}

drill_pipe_pose::LegacySensorFrame legacyOf(const drill_pipe_pose::SensorFrame& frame) {
  drill_pipe_pose::LegacySensorFrame old;
  old.header = frame.header;
  old.camera = frame.camera;
  old.color_info = frame.color_info;
  old.depth = frame.depth;
  old.depth_info = frame.depth_info;
  old.boxes = frame.boxes;
  return old;
}

std::vector<uint8_t> serialize(const drill_pipe_pose::SensorFrame& msg) {
  const uint32_t n = ros::serialization::serializationLength(msg);
  std::vector<uint8_t> buf(n);
  ros::serialization::OStream s(buf.data(), n);
  ros::serialization::serialize(s, msg);
  return buf;
}

}  // namespace drill_pipe_pose_test
