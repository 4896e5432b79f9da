#pragma once
// Pinhole camera model of a RECTIFIED image, built from the fields of a sensor_msgs/CameraInfo
// (ROS-free copy: CameraInfoData). Honours `roi` for images cropped from the full sensor.
// Frames: optical (z forward, x right, y down), metres. Pixels: x right, y down, the centre of
// pixel (u, v) is at (u, v) (REP 104 / image_geometry convention).

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace drill_pipe_pose {

/// A rectangle of a sensor's full image: sensor_msgs/RegionOfInterest. width == height == 0 and
/// zero offsets means "the full image".
struct ImageRoi {
  uint32_t x_offset = 0;  ///< [px] left column of the crop in the full image
  uint32_t y_offset = 0;  ///< [px] top row of the crop in the full image
  uint32_t width = 0;     ///< [px] 0 = full image
  uint32_t height = 0;    ///< [px] 0 = full image
  bool isFull() const { return width == 0 && height == 0 && x_offset == 0 && y_offset == 0; }
  bool operator==(const ImageRoi& o) const {
    return x_offset == o.x_offset && y_offset == o.y_offset && width == o.width &&
           height == o.height;
  }
};

/// The fields of sensor_msgs/CameraInfo, without ROS. Conversions live in the ROS layer.
struct CameraInfoData {
  std::string frame_id;
  uint32_t width = 0;   ///< [px] full sensor image
  uint32_t height = 0;  ///< [px] full sensor image
  std::string distortion_model;
  std::vector<double> D;
  std::array<double, 9> K{};   ///< row-major 3x3
  std::array<double, 9> R{};   ///< row-major 3x3
  std::array<double, 12> P{};  ///< row-major 3x4
  uint32_t binning_x = 0;
  uint32_t binning_y = 0;
  ImageRoi roi;
};

/// Pinhole model of one rectified camera, possibly delivering a cropped image.
class PinholeCamera {
 public:
  PinholeCamera() = default;

  /// Builds the model from a CameraInfo of a rectified image. Intrinsics come from P when P is
  /// set, else from K with all-zero D. Throws InputError naming `source` (e.g. "cam1 depth_info"),
  /// the field and the value for: zero/NaN/negative focal length, non-finite centre, zero size,
  /// non-zero D without P (unrectified image), stereo baseline in P, binning, an roi outside the
  /// sensor.
  static PinholeCamera fromCameraInfo(const CameraInfoData& info, const std::string& source);

  /// Full-sensor model without crop, mainly for tests and the simulator.
  static PinholeCamera fromIntrinsics(uint32_t width, uint32_t height, double fx, double fy,
                                      double cx, double cy);

  /// The same camera delivering only `roi` of its full image (throws InputError if outside).
  PinholeCamera cropped(const ImageRoi& roi, const std::string& source) const;

  double fx() const { return fx_; }                         ///< [px]
  double fy() const { return fy_; }                         ///< [px]
  double cx() const { return cx_; }                         ///< [px] in the FULL sensor image
  double cy() const { return cy_; }                         ///< [px] in the FULL sensor image
  uint32_t sensorWidth() const { return sensor_width_; }    ///< [px] full image
  uint32_t sensorHeight() const { return sensor_height_; }  ///< [px] full image
  uint32_t imageWidth() const { return image_width_; }      ///< [px] delivered (cropped) image
  uint32_t imageHeight() const { return image_height_; }    ///< [px] delivered (cropped) image
  uint32_t offsetX() const { return offset_x_; }            ///< [px] crop offset
  uint32_t offsetY() const { return offset_y_; }            ///< [px] crop offset

  /// The 3D point [m, optical frame] seen at pixel (u, v) of the DELIVERED image at depth z [m]
  /// (z along the optical axis, as depth images store it).
  Eigen::Vector3d backProject(double u, double v, double z) const {
    return {(u + offset_x_ - cx_) / fx_ * z, (v + offset_y_ - cy_) / fy_ * z, z};
  }

  /// Projects a point [m, optical frame] to a pixel of the DELIVERED image. Returns false (and
  /// leaves uv untouched) when the point is not in front of the camera (z <= 0). The pixel may be
  /// outside the image: check with contains().
  bool project(const Eigen::Vector3d& p_optical, Eigen::Vector2d* uv) const {
    if (!(p_optical.z() > 0.0)) return false;
    (*uv) << fx_ * p_optical.x() / p_optical.z() + cx_ - offset_x_,
        fy_ * p_optical.y() / p_optical.z() + cy_ - offset_y_;
    return true;
  }

  /// Whether pixel position uv lies on the delivered image (pixel centres at integers, so the
  /// image covers [-0.5, width - 0.5) x [-0.5, height - 0.5)).
  bool contains(const Eigen::Vector2d& uv) const {
    return uv.x() >= -0.5 && uv.y() >= -0.5 && uv.x() < image_width_ - 0.5 &&
           uv.y() < image_height_ - 0.5;
  }

 private:
  double fx_ = 0, fy_ = 0, cx_ = 0, cy_ = 0;
  uint32_t sensor_width_ = 0, sensor_height_ = 0;
  uint32_t image_width_ = 0, image_height_ = 0;
  uint32_t offset_x_ = 0, offset_y_ = 0;
};

/// Maps depth pixels into the colour image: p_color = T_color_depth * p_depth, then the colour
/// camera's projection. T_color_depth comes from TF (<cam>_rgb_optical_frame <- <cam>_ir_optical_
/// frame), never from a constant.
class DepthToColorRegistration {
 public:
  DepthToColorRegistration(const PinholeCamera& depth, const PinholeCamera& color,
                           const Eigen::Isometry3d& T_color_depth)
      : depth_(depth), color_(color), T_color_depth_(T_color_depth) {}

  /// Colour-image pixel (of the delivered colour image) of the point seen at depth pixel (u, v)
  /// with depth z [m]. False when the point is behind the colour camera.
  bool registerPixel(double u, double v, double z, Eigen::Vector2d* uv_color) const {
    return color_.project(T_color_depth_ * depth_.backProject(u, v, z), uv_color);
  }

  const PinholeCamera& depth() const { return depth_; }
  const PinholeCamera& color() const { return color_; }
  const Eigen::Isometry3d& T_color_depth() const { return T_color_depth_; }

 private:
  PinholeCamera depth_;
  PinholeCamera color_;
  Eigen::Isometry3d T_color_depth_;
};

}  // namespace drill_pipe_pose
