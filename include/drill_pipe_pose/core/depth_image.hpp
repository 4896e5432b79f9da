#pragma once
// Depth images per REP 118 (16UC1 millimetres, 32FC1 metres; 0 or NaN = invalid) and their
// conversion to 3D points through precomputed rays (no full-image cloud is ever required:
// callers visit only the pixels they need).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"

namespace drill_pipe_pose {

enum class DepthEncoding { kU16Millimetres, kF32Metres };

/// "16UC1" or "32FC1" -> encoding; anything else throws InputError naming `source` and the value.
DepthEncoding parseDepthEncoding(const std::string& encoding, const std::string& source);
/// The ROS encoding string ("16UC1" / "32FC1").
const char* depthEncodingName(DepthEncoding e);
/// Bytes per pixel of an encoding.
inline size_t bytesPerPixel(DepthEncoding e) {
  return e == DepthEncoding::kU16Millimetres ? 2 : 4;
}

/// A camera's depth calibration (rig file keys depth_offset, depth_scale; docs/conventions.md):
/// the camera reads z_meas = scale * z_true + offset along its optical axis.
struct DepthCorrection {
  double offset = 0.0;  ///< [m]
  double scale = 1.0;
  /// [m (1/m^2)^4] the camera's own weak-return bias coefficient B (rig file weak_return_bias),
  /// used where the frame carries its amplitude; < 0: the sensor's fitted B.
  double weak_return_bias = -1.0;
  bool isNone() const { return offset == 0.0 && scale == 1.0; }
};

/// A depth image (the fields of sensor_msgs/Image the core needs). The pixel data is shared, not
/// copied: the ROS layer points `data` into the message and keeps the message alive.
struct DepthImage {
  uint32_t width = 0;   ///< [px]
  uint32_t height = 0;  ///< [px]
  DepthEncoding encoding = DepthEncoding::kU16Millimetres;
  uint32_t step = 0;  ///< [bytes] per row
  std::shared_ptr<const uint8_t> data;
  size_t size = 0;  ///< [bytes] available behind data

  /// The depth correction every read applies (setCorrection): z = (z_meas - offset) * gain.
  /// Without one (offset 0, gain 1) a read returns the stored value exactly.
  float correction_offset = 0.0f;  ///< [m]
  float correction_gain = 1.0f;    ///< 1 / DepthCorrection::scale

  /// Depth [m] at pixel (u, v), corrected (setCorrection), or NaN when invalid (0, NaN, inf or
  /// negative, before or after the correction). No bounds check.
  float depthAt(uint32_t u, uint32_t v) const {
    const uint8_t* row = data.get() + static_cast<size_t>(v) * step;
    float z;
    if (encoding == DepthEncoding::kU16Millimetres) {
      uint16_t mm;
      std::memcpy(&mm, row + 2 * u, 2);
      if (mm == 0) return std::numeric_limits<float>::quiet_NaN();
      z = mm * 0.001f;
    } else {
      std::memcpy(&z, row + 4 * u, 4);
      if (!(z > 0.0f && z < std::numeric_limits<float>::infinity()))
        return std::numeric_limits<float>::quiet_NaN();
    }
    z = (z - correction_offset) * correction_gain;
    return z > 0.0f ? z : std::numeric_limits<float>::quiet_NaN();
  }

  /// Reads from now on return the true depth of a camera with this calibration (the pixels are
  /// not rewritten: they may be shared). Throws InputError naming `source` when the correction
  /// is not finite or its scale not positive.
  void setCorrection(const DepthCorrection& c, const std::string& source);

  /// A new zero-filled (all invalid) image owning its data.
  static DepthImage allocate(uint32_t width, uint32_t height, DepthEncoding encoding);
  /// Writable access for images made with allocate() (simulator, tests).
  uint8_t* mutableData() { return const_cast<uint8_t*>(data.get()); }
  /// Writes depth z [m] at (u, v), rounding to 1 mm for 16UC1; NaN/<=0 writes "invalid". The
  /// stored value: no correction applies.
  void setDepth(uint32_t u, uint32_t v, float z);
};

/// The IR amplitude image a time-of-flight camera delivers beside its depth (kinect2_bridge:
/// `sd/image_ir_rect`, 16UC1), on the depth image's grid and crop: pixel (u, v) is the
/// amplitude of depth pixel (u, v). Optional: an empty one (width 0) means "not available".
/// Values are the driver's digital numbers [DN]; EstimatorConfig::noise.amplitude_scale turns
/// them into the amplitude the noise model uses. The data is shared, as DepthImage's.
struct AmplitudeImage {
  uint32_t width = 0;   ///< [px]
  uint32_t height = 0;  ///< [px]
  bool f32 = false;     ///< 32FC1 (floats) instead of 16UC1 / mono16
  uint32_t step = 0;    ///< [bytes] per row
  std::shared_ptr<const uint8_t> data;
  size_t size = 0;  ///< [bytes] available behind data

  bool empty() const { return width == 0 || height == 0; }
  size_t bytesPerPixel() const { return f32 ? 4 : 2; }
  /// The amplitude [DN] at pixel (u, v); 0 for a NaN or negative float. No bounds check.
  float at(uint32_t u, uint32_t v) const {
    const uint8_t* row = data.get() + static_cast<size_t>(v) * step;
    if (!f32) {
      uint16_t dn;
      std::memcpy(&dn, row + 2 * u, 2);
      return dn;
    }
    float a;
    std::memcpy(&a, row + 4 * u, 4);
    return a > 0.0f && a < std::numeric_limits<float>::infinity() ? a : 0.0f;
  }
  /// A new zero-filled image owning its data, 16UC1 (or 32FC1 with f32).
  static AmplitudeImage allocate(uint32_t width, uint32_t height, bool f32 = false);
  /// Writable access for images made with allocate().
  uint8_t* mutableData() { return const_cast<uint8_t*>(data.get()); }
  /// Writes `dn` at (u, v) of an allocate()d 16UC1 image, rounded and clamped to 0-65535.
  void set(uint32_t u, uint32_t v, float dn);
};

/// "16UC1" / "mono16" -> false, "32FC1" -> true (AmplitudeImage::f32); anything else throws
/// InputError naming `source` and the value.
bool parseAmplitudeEncoding(const std::string& encoding, const std::string& source);

/// Why `amplitude` cannot be read beside `depth` (its size differs: another grid or crop; its
/// step or data too short), naming `source` and the field; empty when it can, or is empty.
std::string amplitudeMismatch(const AmplitudeImage& amplitude, const DepthImage& depth,
                              const std::string& source);

/// Checks an image against the camera that delivered it: size equal to the camera's (roi-aware)
/// image size, step >= width * bytes per pixel, data large enough. Throws InputError naming
/// `source`, the field and the value.
void validateDepthImage(const DepthImage& image, const PinholeCamera& camera,
                        const std::string& source);

/// Converts depth pixels to 3D points of the depth camera's optical frame through per-column and
/// per-row ray tables (for a rectified pinhole camera, the ray of pixel (u, v) is
/// (rx[u], ry[v], 1), so two tables ARE the per-pixel rays, at a fraction of the memory).
class DepthProjector {
 public:
  DepthProjector() = default;
  explicit DepthProjector(const PinholeCamera& camera);

  const PinholeCamera& camera() const { return camera_; }

  /// The point [m, optical frame] at pixel (u, v) of an image validated against camera(); false
  /// when the pixel is invalid. No bounds check.
  bool pointAt(const DepthImage& image, uint32_t u, uint32_t v, Eigen::Vector3f* p) const {
    const float z = image.depthAt(u, v);
    if (!(z == z)) return false;
    (*p) << ray_x_[u] * z, ray_y_[v] * z, z;
    return true;
  }

  /// Calls f(u, v, point) for every valid pixel of the rectangle [u0, u1) x [v0, v1) of the
  /// delivered image (clamped to the image). Touches only that rectangle.
  template <typename F>
  void forEachPoint(const DepthImage& image, int u0, int v0, int u1, int v1, F&& f) const {
    u0 = std::max(u0, 0);
    v0 = std::max(v0, 0);
    u1 = std::min<int>(u1, static_cast<int>(image.width));
    v1 = std::min<int>(v1, static_cast<int>(image.height));
    Eigen::Vector3f p;
    for (int v = v0; v < v1; ++v)
      for (int u = u0; u < u1; ++u)
        if (pointAt(image, u, v, &p)) f(u, v, p);
  }

  /// Every valid point of the image (tests and tools; the estimator never needs a full cloud).
  std::vector<Eigen::Vector3f> allPoints(const DepthImage& image) const;

 private:
  PinholeCamera camera_;
  std::vector<float> ray_x_;  ///< x/z of each column of the delivered image
  std::vector<float> ray_y_;  ///< y/z of each row of the delivered image
};

}  // namespace drill_pipe_pose
