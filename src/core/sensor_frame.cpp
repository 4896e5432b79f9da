// Size limits of one SensorFrame (sensor_frame.hpp).

#include "drill_pipe_pose/core/sensor_frame.hpp"

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

void checkFrameLimits(const std::string& camera, uint64_t depth_width, uint64_t depth_height,
                      uint64_t color_width, uint64_t color_height, uint64_t depth_info_width,
                      uint64_t depth_info_height, uint64_t boxes, const InputLimits& limits) {
  const auto pixels = [&](const char* field, uint64_t w, uint64_t h) {
    // w and h are 32-bit on the wire: their product fits in 64 bits.
    if (w * h > limits.max_image_pixels)
      fail(camera, ' ', field, ": ", w, " x ", h, " = ", w * h, " pixels exceeds limits/max_image_pixels = ",
           limits.max_image_pixels, " (frame dropped)");
  };
  pixels("depth", depth_width, depth_height);
  pixels("color_info", color_width, color_height);
  pixels("depth_info", depth_info_width, depth_info_height);
  if (boxes > limits.max_boxes)
    fail(camera, " boxes: ", boxes, " boxes exceed limits/max_boxes = ", limits.max_boxes,
         " (frame dropped)");
}

}  // namespace drill_pipe_pose
