#pragma once
// ROS-free form of drill_pipe_pose/SensorFrame: what one sensor node sends per colour frame.

#include <cstdint>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"

namespace drill_pipe_pose {

/// A 2D detection in the full colour image [px], x right, y down.
struct DetectionBox {
  EndLabel label = EndLabel::kBoxEnd;
  float confidence = 0.0f;  ///< [0, 1]
  float x_min = 0, y_min = 0, x_max = 0, y_max = 0;
};

struct SensorFrameData {
  std::string camera;    ///< sensor node name (<cam>)
  int64_t stamp_ns = 0;  ///< capture time of the colour image [ns since epoch]
  std::string frame_id;  ///< colour optical frame
  CameraInfoData color_info;
  CameraInfoData depth_info;
  int64_t depth_stamp_ns = 0;  ///< capture time of the depth image [ns]
  std::string depth_frame_id;  ///< depth optical frame
  DepthImage depth;
  std::vector<DetectionBox> boxes;
};

}  // namespace drill_pipe_pose
