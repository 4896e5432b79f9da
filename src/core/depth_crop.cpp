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

SensorFrameData cropDepthToBoxes(const SensorFrameData& frame,
                                 const Eigen::Isometry3d& T_color_depth,
                                 const DepthCropConfig& config) {
  const CycleCamera cam =
      makeCycleCamera(frame, Eigen::Isometry3d::Identity(), T_color_depth, 0.0f);
  std::array<int, 4> r{{0, 0, 1, 1}};
  const bool empty = !depthCropRect(cam, config, &r);
  const int u0 = r[0], v0 = r[1], u1 = r[2], v1 = r[3];
  SensorFrameData out = frame;
  const size_t bpp = bytesPerPixel(frame.depth.encoding);
  DepthImage crop = DepthImage::allocate(u1 - u0, v1 - v0, frame.depth.encoding);
  if (!empty)
    for (int v = v0; v < v1; ++v)
      std::memcpy(crop.mutableData() + static_cast<size_t>(v - v0) * crop.step,
                  frame.depth.data.get() + static_cast<size_t>(v) * frame.depth.step + u0 * bpp,
                  (u1 - u0) * bpp);
  out.depth = crop;
  // The amplitude, on the depth's grid, is cropped to the same rectangle.
  if (!frame.amplitude.empty() && amplitudeMismatch(frame.amplitude, frame.depth, "").empty()) {
    const size_t abpp = frame.amplitude.f32 ? 4 : 2;
    AmplitudeImage a;
    a.width = u1 - u0;
    a.height = v1 - v0;
    a.f32 = frame.amplitude.f32;
    a.step = static_cast<uint32_t>(a.width * abpp);
    a.size = static_cast<size_t>(a.step) * a.height;
    auto buf = std::shared_ptr<uint8_t>(new uint8_t[std::max<size_t>(a.size, 1)](),
                                        std::default_delete<uint8_t[]>());
    if (!empty)
      for (int v = v0; v < v1; ++v)
        std::memcpy(buf.get() + static_cast<size_t>(v - v0) * a.step,
                    frame.amplitude.data.get() + static_cast<size_t>(v) * frame.amplitude.step +
                        u0 * abpp,
                    (u1 - u0) * abpp);
    a.data = buf;
    out.amplitude = a;
  } else {
    out.amplitude = AmplitudeImage();
  }
  out.depth_info.roi.x_offset = cam.depth.offsetX() + u0;
  out.depth_info.roi.y_offset = cam.depth.offsetY() + v0;
  out.depth_info.roi.width = u1 - u0;
  out.depth_info.roi.height = v1 - v0;
  return out;
}

}  // namespace drill_pipe_pose
