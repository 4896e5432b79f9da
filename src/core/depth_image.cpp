#include "drill_pipe_pose/core/depth_image.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

DepthEncoding parseDepthEncoding(const std::string& encoding, const std::string& source) {
  if (encoding == "16UC1") return DepthEncoding::kU16Millimetres;
  if (encoding == "32FC1") return DepthEncoding::kF32Metres;
  fail(source, ": encoding = \"", encoding,
       "\" is not a supported depth encoding (16UC1 millimetres or 32FC1 metres, REP 118)");
}

const char* depthEncodingName(DepthEncoding e) {
  return e == DepthEncoding::kU16Millimetres ? "16UC1" : "32FC1";
}

DepthImage DepthImage::allocate(uint32_t width, uint32_t height, DepthEncoding encoding) {
  DepthImage img;
  img.width = width;
  img.height = height;
  img.encoding = encoding;
  img.step = static_cast<uint32_t>(width * bytesPerPixel(encoding));
  img.size = static_cast<size_t>(img.step) * height;
  auto buf = std::shared_ptr<uint8_t>(new uint8_t[img.size](), std::default_delete<uint8_t[]>());
  img.data = buf;
  return img;
}

void DepthImage::setDepth(uint32_t u, uint32_t v, float z) {
  uint8_t* px = mutableData() + static_cast<size_t>(v) * step + u * bytesPerPixel(encoding);
  if (encoding == DepthEncoding::kU16Millimetres) {
    const float mm = std::round(z * 1000.0f);
    const uint16_t q = (z > 0.0f && mm < 65535.0f) ? static_cast<uint16_t>(mm) : 0;
    std::memcpy(px, &q, 2);
  } else {
    const float m = z > 0.0f ? z : std::numeric_limits<float>::quiet_NaN();
    std::memcpy(px, &m, 4);
  }
}

void DepthImage::setCorrection(const DepthCorrection& c, const std::string& source) {
  if (!std::isfinite(c.offset) || !std::isfinite(c.scale) || !(c.scale > 0.0))
    fail(source, ": depth correction (offset ", c.offset, " m, scale ", c.scale,
         ") is not finite or its scale not positive");
  correction_offset = static_cast<float>(c.offset);
  correction_gain = static_cast<float>(1.0 / c.scale);
}

AmplitudeImage AmplitudeImage::allocate(uint32_t width, uint32_t height, bool f32) {
  AmplitudeImage img;
  img.width = width;
  img.height = height;
  img.f32 = f32;
  img.step = static_cast<uint32_t>(width * img.bytesPerPixel());
  img.size = static_cast<size_t>(img.step) * height;
  img.data = std::shared_ptr<uint8_t>(new uint8_t[img.size](), std::default_delete<uint8_t[]>());
  return img;
}

void AmplitudeImage::set(uint32_t u, uint32_t v, float dn) {
  const float c = std::clamp(std::round(dn), 0.0f, 65535.0f);
  const uint16_t x = c == c ? static_cast<uint16_t>(c) : 0;
  std::memcpy(mutableData() + static_cast<size_t>(v) * step + 2 * u, &x, 2);
}

bool parseAmplitudeEncoding(const std::string& encoding, const std::string& source) {
  if (encoding == "16UC1" || encoding == "mono16") return false;
  if (encoding == "32FC1") return true;
  fail(source, ": encoding = \"", encoding,
       "\" is not a supported amplitude encoding (16UC1, mono16 or 32FC1)");
}

std::string amplitudeMismatch(const AmplitudeImage& amplitude, const DepthImage& depth,
                              const std::string& source) {
  if (amplitude.empty()) return "";
  std::ostringstream s;
  if (amplitude.width != depth.width || amplitude.height != depth.height) {
    s << source << ": amplitude image is " << amplitude.width << "x" << amplitude.height
      << " but the depth image is " << depth.width << "x" << depth.height
      << " (another grid or crop): amplitude ignored, depth used without it";
    return s.str();
  }
  const size_t bpp = amplitude.bytesPerPixel();
  if (amplitude.step < amplitude.width * bpp) {
    s << source << ": amplitude image step = " << amplitude.step << " bytes is less than width * "
      << bpp << ": amplitude ignored, depth used without it";
    return s.str();
  }
  const size_t need = static_cast<size_t>(amplitude.step) * amplitude.height;
  if (!amplitude.data || amplitude.size < need) {
    s << source << ": amplitude image data has " << amplitude.size << " bytes, step * height = "
      << need << " expected: amplitude ignored, depth used without it";
    return s.str();
  }
  return "";
}

void validateDepthImage(const DepthImage& image, const PinholeCamera& camera,
                        const std::string& source) {
  if (image.width != camera.imageWidth() || image.height != camera.imageHeight())
    fail(source, ": depth image is ", image.width, "x", image.height, " but its CameraInfo",
         (camera.imageWidth() == camera.sensorWidth() && camera.offsetX() == 0 ? "" : " roi"),
         " says ", camera.imageWidth(), "x", camera.imageHeight());
  const size_t min_step = static_cast<size_t>(image.width) * bytesPerPixel(image.encoding);
  if (image.step < min_step)
    fail(source, ": depth image step = ", image.step, " bytes is less than width * ",
         bytesPerPixel(image.encoding), " = ", min_step, " for ",
         depthEncodingName(image.encoding));
  const size_t need = static_cast<size_t>(image.step) * image.height;
  if (!image.data || image.size < need)
    fail(source, ": depth image data has ", image.size, " bytes, step * height = ", need,
         " expected");
}

DepthProjector::DepthProjector(const PinholeCamera& camera) : camera_(camera) {
  ray_x_.resize(camera.imageWidth());
  ray_y_.resize(camera.imageHeight());
  for (uint32_t u = 0; u < camera.imageWidth(); ++u)
    ray_x_[u] = static_cast<float>((u + camera.offsetX() - camera.cx()) / camera.fx());
  for (uint32_t v = 0; v < camera.imageHeight(); ++v)
    ray_y_[v] = static_cast<float>((v + camera.offsetY() - camera.cy()) / camera.fy());
}

std::vector<Eigen::Vector3f> DepthProjector::allPoints(const DepthImage& image) const {
  std::vector<Eigen::Vector3f> pts;
  forEachPoint(image, 0, 0, image.width, image.height,
               [&](int, int, const Eigen::Vector3f& p) { pts.push_back(p); });
  return pts;
}

}  // namespace drill_pipe_pose
