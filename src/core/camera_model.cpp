#include "drill_pipe_pose/core/camera_model.hpp"

#include <cmath>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {
namespace {

void checkFocal(double f, const std::string& source, const char* field) {
  if (!std::isfinite(f) || f <= 0.0)
    fail(source, ": ", field, " = ", f, " is not a valid focal length (must be finite and > 0)");
}

void checkFinite(double x, const std::string& source, const char* field) {
  if (!std::isfinite(x)) fail(source, ": ", field, " = ", x, " is not finite");
}

}  // namespace

PinholeCamera PinholeCamera::fromIntrinsics(uint32_t width, uint32_t height, double fx, double fy,
                                            double cx, double cy) {
  CameraInfoData info;
  info.width = width;
  info.height = height;
  info.K = {fx, 0, cx, 0, fy, cy, 0, 0, 1};
  info.P = {fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0};
  return fromCameraInfo(info, "intrinsics");
}

PinholeCamera PinholeCamera::fromCameraInfo(const CameraInfoData& info, const std::string& source) {
  if (info.width == 0 || info.height == 0)
    fail(source, ": image size width = ", info.width, ", height = ", info.height,
         " (both must be > 0)");
  if (info.binning_x > 1 || info.binning_y > 1)
    fail(source, ": binning_x = ", info.binning_x, ", binning_y = ", info.binning_y,
         " is not supported (publish unbinned images)");

  PinholeCamera cam;
  const bool p_set = info.P[0] != 0.0 || info.P[5] != 0.0;
  if (p_set) {
    // Rectified image: P holds the intrinsics of the rectified camera; D does not apply.
    checkFocal(info.P[0], source, "P[0] (fx)");
    checkFocal(info.P[5], source, "P[5] (fy)");
    checkFinite(info.P[2], source, "P[2] (cx)");
    checkFinite(info.P[6], source, "P[6] (cy)");
    if (info.P[3] != 0.0 || info.P[7] != 0.0)
      fail(source, ": P[3] = ", info.P[3], ", P[7] = ", info.P[7],
           " (stereo baseline): only a monocular / left camera is supported");
    if (info.P[1] != 0.0)
      fail(source, ": P[1] (skew) = ", info.P[1], " is not supported (must be 0)");
    cam.fx_ = info.P[0];
    cam.fy_ = info.P[5];
    cam.cx_ = info.P[2];
    cam.cy_ = info.P[6];
  } else {
    // No P: only an undistorted image can be used through K.
    for (size_t i = 0; i < info.D.size(); ++i)
      if (info.D[i] != 0.0)
        fail(source, ": D[", i, "] = ", info.D[i],
             " with P unset: the image is not rectified (publish the rectified image, or a P)");
    checkFocal(info.K[0], source, "K[0] (fx)");
    checkFocal(info.K[4], source, "K[4] (fy)");
    checkFinite(info.K[2], source, "K[2] (cx)");
    checkFinite(info.K[5], source, "K[5] (cy)");
    if (info.K[1] != 0.0)
      fail(source, ": K[1] (skew) = ", info.K[1], " is not supported (must be 0)");
    cam.fx_ = info.K[0];
    cam.fy_ = info.K[4];
    cam.cx_ = info.K[2];
    cam.cy_ = info.K[5];
  }
  cam.sensor_width_ = cam.image_width_ = info.width;
  cam.sensor_height_ = cam.image_height_ = info.height;
  if (info.roi.isFull()) return cam;
  return cam.cropped(info.roi, source);
}

PinholeCamera PinholeCamera::cropped(const ImageRoi& roi, const std::string& source) const {
  if (roi.width == 0 || roi.height == 0)
    fail(source, ": roi.width = ", roi.width, ", roi.height = ", roi.height,
         " with roi.x_offset = ", roi.x_offset, ", roi.y_offset = ", roi.y_offset,
         " (a crop needs a non-zero size)");
  if (uint64_t{roi.x_offset} + roi.width > sensor_width_)
    fail(source, ": roi.x_offset + roi.width = ", uint64_t{roi.x_offset} + roi.width,
         " is outside the sensor (width = ", sensor_width_, ")");
  if (uint64_t{roi.y_offset} + roi.height > sensor_height_)
    fail(source, ": roi.y_offset + roi.height = ", uint64_t{roi.y_offset} + roi.height,
         " is outside the sensor (height = ", sensor_height_, ")");
  PinholeCamera c = *this;
  c.offset_x_ = roi.x_offset;
  c.offset_y_ = roi.y_offset;
  c.image_width_ = roi.width;
  c.image_height_ = roi.height;
  return c;
}

}  // namespace drill_pipe_pose
