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
  /// The IR amplitude on the depth image's grid and crop; empty when the camera sends none or
  /// when it was refused (amplitude_refused says why: the depth is used without it).
  AmplitudeImage amplitude;
  std::string amplitude_refused;
  std::vector<DetectionBox> boxes;
};

/// Size limits of one SensorFrame. A message can be arbitrarily large on the wire; a frame beyond
/// a limit is rejected before anything is allocated for it (checkFrameLimits).
struct InputLimits {
  /// Depth image width x height, and each CameraInfo's (Kinect v2: 512 x 424 depth, 1920 x 1080
  /// colour; the default leaves room for 4K colour).
  uint64_t max_image_pixels = 4096ull * 4096ull;
  /// Boxes per frame (a detector boxes a handful of ends; 1000 boxes is a broken detector).
  uint64_t max_boxes = 64;
};

/// Throws InputError naming `camera`, the field and the limit when a declared size exceeds
/// `limits`: the depth image (width x height), a CameraInfo (`info_name`: width x height), the box
/// count.
void checkFrameLimits(const std::string& camera, uint64_t depth_width, uint64_t depth_height,
                      uint64_t color_width, uint64_t color_height, uint64_t depth_info_width,
                      uint64_t depth_info_height, uint64_t boxes, const InputLimits& limits);

}  // namespace drill_pipe_pose
