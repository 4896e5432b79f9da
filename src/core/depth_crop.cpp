#include "drill_pipe_pose/core/depth_crop.hpp"

#include <algorithm>
#include <cstring>

#include "drill_pipe_pose/core/estimator/stages.hpp"

namespace drill_pipe_pose {

bool depthCropRect(const CycleCamera& cam, const DepthCropConfig& config,
                   std::array<int, 4>* rect) {
  int u0 = INT32_MAX, v0 = INT32_MAX, u1 = INT32_MIN, v1 = INT32_MIN;
  for (const auto& box : cam.boxes) {
    std::array<int, 4> r;
    if (!depthRectOfBox(cam, box, config.margin_px, config.min_range, config.max_range, &r))
      continue;
    u0 = std::min(u0, r[0]);
    v0 = std::min(v0, r[1]);
    u1 = std::max(u1, r[2]);
    v1 = std::max(v1, r[3]);
  }
  if (u0 >= u1 || v0 >= v1) return false;
  *rect = {{u0, v0, u1, v1}};
  return true;
}

namespace {

/// Copies the pixels [u0, u1) x [v0, v1) of `rect` (bpp bytes each) from an image with rows of
/// src_step bytes into one with rows of dst_step bytes.
void copyRect(const uint8_t* src, size_t src_step, size_t bpp, const std::array<int, 4>& rect,
              uint8_t* dst, size_t dst_step) {
  const auto [u0, v0, u1, v1] = rect;
  for (int v = v0; v < v1; ++v)
    std::memcpy(dst + static_cast<size_t>(v - v0) * dst_step,
                src + static_cast<size_t>(v) * src_step + u0 * bpp, (u1 - u0) * bpp);
}

}  // namespace

SensorFrameData cropDepthToBoxes(const SensorFrameData& frame,
                                 const Eigen::Isometry3d& T_color_depth,
                                 const DepthCropConfig& config) {
  const CycleCamera cam =
      makeCycleCamera(frame, Eigen::Isometry3d::Identity(), T_color_depth, 0.0f);
  std::array<int, 4> r{{0, 0, 1, 1}};
  const bool empty = !depthCropRect(cam, config, &r);
  const int u0 = r[0], v0 = r[1], u1 = r[2], v1 = r[3];
  SensorFrameData out = frame;
  out.depth = DepthImage::allocate(u1 - u0, v1 - v0, frame.depth.encoding);
  if (!empty)
    copyRect(frame.depth.data.get(), frame.depth.step, bytesPerPixel(frame.depth.encoding), r,
             out.depth.mutableData(), out.depth.step);
  // The amplitude, on the depth's grid, is cropped to the same rectangle.
  out.amplitude = AmplitudeImage();
  if (!frame.amplitude.empty() && amplitudeMismatch(frame.amplitude, frame.depth, "").empty()) {
    out.amplitude = AmplitudeImage::allocate(u1 - u0, v1 - v0, frame.amplitude.f32);
    if (!empty)
      copyRect(frame.amplitude.data.get(), frame.amplitude.step, frame.amplitude.bytesPerPixel(), r,
               out.amplitude.mutableData(), out.amplitude.step);
  }
  out.depth_info.roi.x_offset = cam.depth.offsetX() + u0;
  out.depth_info.roi.y_offset = cam.depth.offsetY() + v0;
  out.depth_info.roi.width = u1 - u0;
  out.depth_info.roi.height = v1 - v0;
  return out;
}

}  // namespace drill_pipe_pose
