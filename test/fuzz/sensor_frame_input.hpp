#pragma once
// The input format of fuzz_sensor_frame: bytes -> up to three drill_pipe_pose/SensorFrame
// messages (as a sensor node would publish them, field by field) plus what the node adds to each
// before the estimator sees it (the TF transforms and the rig file's depth correction). The
// encoder writes the same format from real messages: the seed generator (make_seeds.cpp) turns
// simulated frames into seed inputs with it.
//
// Layout (FuzzReader coding, fuzz_input.hpp):
//   u8 flags: bits 0-1: frames - 1 (3 reads as 3 frames); bit 2: run a second cycle
//   per frame:
//     header (stamp: u32 sec, u32 nsec; frame_id: text), camera: text
//     color_info: CameraInfo, depth: Image, depth_info: CameraInfo, boxes: Boxes
//     T_world_depth: Transform, T_color_depth: Transform, correction: u8 mode [+ f64 offset, scale]
//   then per frame: u8 (bit 0: an amplitude Image follows), so that inputs written before the
//     amplitude existed read as before (their missing bytes are zeros: no amplitude)
//   CameraInfo: u8 mode: 0 = every field follows; 1 / 2 = a Kinect v2 depth / colour preset;
//     3 = the depth preset with the 4 roi dims following.
//     Fields: header, width dim, height dim, distortion_model text, u8 |D| (mod 9) x f64,
//     K 9 x f64, R 9 x f64, P 12 x f64, binning_x dim, binning_y dim, roi: x_offset, y_offset,
//     width, height dims, do_rectify u8
//   Image: header, height dim, width dim, encoding text, is_bigendian u8, step (u8 mode: 0 = the
//     encoding's width x bytes per pixel, 1 = that + u8 padding, 2 = dim, 3 = 0, else as 0), data
//     (u8 mode: 0 = step x height bytes, 1 = that minus (u16 + 1), 2 = u32 % (cap + 1) bytes, each
//     filled by a pattern; 3 = u32 length of literal bytes that follow; 4 = empty), all capped at
//     kMaxDepthBytes however large the declared image is (the declared 20000 x 20000 image then
//     comes with short data, as a corrupt or truncated message would)
//   pattern: u8 mode: 0 = one coded f32 depth [m] everywhere (in the encoding), 1 = u8 + 1 bytes
//     repeated, 2 = a tilted plane with noise from a u32 seed, 3 = zeros
//   Boxes: u8 n: 0xFE = one box repeated u16 % 5001 times (a huge list), 0xFF = u16 % 2049 boxes,
//     else n % 9 boxes; Box: label text, confidence f32, x_min, y_min, x_max, y_max f32
//   Transform: u8 mode: 0 = identity, 1 = a camera 6 m from the origin looking at it, 2 =
//     quaternion (x y z w) 4 x f64 (normalised when it can be) + translation 3 x f64, 3 = NaN

#include <drill_pipe_pose/SensorFrame.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "fuzz_input.hpp"

namespace drill_pipe_pose::fuzz {

/// Most depth bytes a fuzz input carries (a Kinect v2 SD frame in 32FC1 is 868 KB).
constexpr size_t kMaxDepthBytes = size_t{1} << 20;

/// One camera's frame as the estimator node would assemble it.
struct FuzzCamera {
  SensorFrame msg;
  Eigen::Isometry3d T_world_depth = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_color_depth = Eigen::Isometry3d::Identity();
  DepthCorrection correction;
};

struct FuzzSensorInput {
  std::vector<FuzzCamera> cameras;
  bool second_cycle = false;
};

namespace detail {

inline const std::vector<std::string>& knownFrameIds() {
  static const std::vector<std::string> v = {"", "cam1_rgb_optical_frame",
                                             "cam1_ir_optical_frame", "world", "cam2_link"};
  return v;
}
inline const std::vector<std::string>& knownCameras() {
  static const std::vector<std::string> v = {"cam1", "cam2", "", "cam 1", "cam1/../x"};
  return v;
}
inline const std::vector<std::string>& knownEncodings() {
  static const std::vector<std::string> v = {"16UC1", "32FC1", "mono16", "16SC1", "8UC1",
                                             "32FC2", "bgr8",  "",       "16uc1"};
  return v;
}
inline const std::vector<std::string>& knownLabels() {
  static const std::vector<std::string> v = {"box_end", "pin_end", "",     "BOX_END",
                                             "box_end ", "pipe",   "pin"};
  return v;
}
inline const std::vector<std::string>& knownDistortion() {
  static const std::vector<std::string> v = {"plumb_bob", "rational_polynomial", "", "equidistant"};
  return v;
}

inline void readHeader(FuzzReader& r, std_msgs::Header* h) {
  h->stamp.sec = r.u32();
  h->stamp.nsec = r.u32();
  h->frame_id = r.text(knownFrameIds());
}
inline void writeHeader(FuzzWriter& w, const std_msgs::Header& h) {
  w.u32(h.stamp.sec);
  w.u32(h.stamp.nsec);
  w.text(h.frame_id);
}

/// Kinect v2 presets (config/sensors/kinect_v2.yaml): SD depth 512x424, QHD colour 960x540.
inline sensor_msgs::CameraInfo presetInfo(bool depth) {
  sensor_msgs::CameraInfo c;
  c.distortion_model = "plumb_bob";
  c.D = {0, 0, 0, 0, 0};
  c.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  if (depth) {
    c.header.frame_id = "cam1_ir_optical_frame";
    c.width = 512;
    c.height = 424;
    c.K = {365.4, 0, 260.9, 0, 365.4, 205.6, 0, 0, 1};
    c.P = {365.4, 0, 260.9, 0, 0, 365.4, 205.6, 0, 0, 0, 1, 0};
  } else {
    c.header.frame_id = "cam1_rgb_optical_frame";
    c.width = 960;
    c.height = 540;
    c.K = {540.7, 0, 479.75, 0, 540.7, 269.75, 0, 0, 1};
    c.P = {540.7, 0, 479.75, 0, 0, 540.7, 269.75, 0, 0, 0, 1, 0};
  }
  return c;
}

inline void readInfo(FuzzReader& r, sensor_msgs::CameraInfo* c) {
  const uint8_t mode = r.u8() % 4;
  if (mode == 1 || mode == 2) {
    *c = presetInfo(mode == 1);
    return;
  }
  if (mode == 3) {
    *c = presetInfo(true);
    c->roi.x_offset = r.dim();
    c->roi.y_offset = r.dim();
    c->roi.width = r.dim();
    c->roi.height = r.dim();
    return;
  }
  readHeader(r, &c->header);
  c->width = r.dim();
  c->height = r.dim();
  c->distortion_model = r.text(knownDistortion());
  c->D.resize(r.u8() % 9);
  for (double& d : c->D) d = r.f64();
  for (double& k : c->K) k = r.f64();
  for (double& k : c->R) k = r.f64();
  for (double& p : c->P) p = r.f64();
  c->binning_x = r.dim();
  c->binning_y = r.dim();
  c->roi.x_offset = r.dim();
  c->roi.y_offset = r.dim();
  c->roi.width = r.dim();
  c->roi.height = r.dim();
  c->roi.do_rectify = r.u8() & 1;
}
inline void writeInfo(FuzzWriter& w, const sensor_msgs::CameraInfo& c) {
  w.u8(0);
  writeHeader(w, c.header);
  w.dim(c.width);
  w.dim(c.height);
  w.text(c.distortion_model);
  w.u8(static_cast<uint8_t>(std::min<size_t>(c.D.size(), 8)));
  for (size_t i = 0; i < c.D.size() && i < 8; ++i) w.f64(c.D[i]);
  for (double k : c.K) w.f64(k);
  for (double k : c.R) w.f64(k);
  for (double p : c.P) w.f64(p);
  w.dim(c.binning_x);
  w.dim(c.binning_y);
  w.dim(c.roi.x_offset);
  w.dim(c.roi.y_offset);
  w.dim(c.roi.width);
  w.dim(c.roi.height);
  w.u8(c.roi.do_rectify);
}

/// Fills `data` with a pattern of depths in `encoding` (16UC1 mm, anything else as 32FC1 m).
inline void fillPattern(FuzzReader& r, const std::string& encoding, uint32_t width,
                        std::vector<uint8_t>* data) {
  const bool mm = encoding != "32FC1";
  const size_t bpp = mm ? 2 : 4;
  auto put = [&](size_t i, float z) {
    if (mm) {
      const float v = std::round(z * 1000.0f);
      const uint16_t q = v > 0.0f && v < 65535.0f ? static_cast<uint16_t>(v) : 0;
      std::memcpy(data->data() + i, &q, std::min(bpp, data->size() - i));
    } else {
      std::memcpy(data->data() + i, &z, std::min(bpp, data->size() - i));
    }
  };
  switch (r.u8() % 4) {
    case 0: {
      const float z = r.f32();
      for (size_t i = 0; i < data->size(); i += bpp) put(i, z);
      break;
    }
    case 1: {
      const std::vector<uint8_t> tile = r.bytes(size_t{r.u8()} + 1);
      for (size_t i = 0; i < data->size(); ++i) (*data)[i] = tile[i % tile.size()];
      break;
    }
    case 2: {
      uint32_t s = r.u32() | 1u;
      const size_t row = std::max<size_t>(1, size_t{width} * bpp);
      for (size_t i = 0; i < data->size(); i += bpp) {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        const float u = static_cast<float>((i % row) / bpp), v = static_cast<float>(i / row);
        put(i, 5.0f + 0.002f * u - 0.001f * v + 0.01f * ((s & 0xFF) / 255.0f - 0.5f));
      }
      break;
    }
    default:
      break;  // zeros: every pixel invalid
  }
}

inline void readImage(FuzzReader& r, sensor_msgs::Image* m) {
  readHeader(r, &m->header);
  m->height = r.dim();
  m->width = r.dim();
  m->encoding = r.text(knownEncodings());
  m->is_bigendian = r.u8();
  const uint64_t bpp = m->encoding == "32FC1" ? 4 : 2;
  const uint64_t exact_step = uint64_t{m->width} * bpp;
  switch (r.u8() % 5) {
    case 0: m->step = static_cast<uint32_t>(exact_step); break;
    case 1: m->step = static_cast<uint32_t>(exact_step + r.u8()); break;
    case 2: m->step = r.dim(); break;
    default: m->step = 0; break;
  }
  const uint64_t exact = uint64_t{m->step} * m->height;
  const uint8_t mode = r.u8() % 5;
  uint64_t n = 0;
  if (mode == 0) n = exact;
  if (mode == 1) {
    const uint64_t cut = uint64_t{r.u16()} + 1;
    n = exact > cut ? exact - cut : 0;
  }
  if (mode == 2) n = r.u32() % (kMaxDepthBytes + 1);
  if (mode == 3) {
    n = std::min<uint64_t>(r.u32(), std::min(kMaxDepthBytes, r.remaining()));
    m->data = r.bytes(n);
    return;
  }
  m->data.assign(std::min<uint64_t>(n, kMaxDepthBytes), 0);
  if (!m->data.empty()) fillPattern(r, m->encoding, m->width, &m->data);
}
inline void writeImage(FuzzWriter& w, const sensor_msgs::Image& m) {
  writeHeader(w, m.header);
  w.dim(m.height);
  w.dim(m.width);
  w.text(m.encoding);
  w.u8(m.is_bigendian);
  w.u8(2);
  w.dim(m.step);
  w.u8(3);
  w.u32(static_cast<uint32_t>(m.data.size()));
  w.write(m.data.data(), m.data.size());
}

inline PipeBox readBox(FuzzReader& r) {
  PipeBox b;
  b.label = r.text(knownLabels());
  b.confidence = r.f32();
  b.x_min = r.f32();
  b.y_min = r.f32();
  b.x_max = r.f32();
  b.y_max = r.f32();
  return b;
}
inline void writeBox(FuzzWriter& w, const PipeBox& b) {
  w.text(b.label);
  w.f32(b.confidence);
  w.f32(b.x_min);
  w.f32(b.y_min);
  w.f32(b.x_max);
  w.f32(b.y_max);
}

inline void readBoxes(FuzzReader& r, std::vector<PipeBox>* boxes) {
  const uint8_t n = r.u8();
  if (n == 0xFE) {
    const PipeBox b = readBox(r);
    boxes->assign(r.u16() % 5001, b);
  } else {
    const size_t count = n == 0xFF ? r.u16() % 2049 : n % 9;
    for (size_t i = 0; i < count; ++i) boxes->push_back(readBox(r));
  }
}
inline void writeBoxes(FuzzWriter& w, const std::vector<PipeBox>& boxes) {
  w.u8(0xFF);
  w.u16(static_cast<uint16_t>(std::min<size_t>(boxes.size(), 2048)));
  for (size_t i = 0; i < boxes.size() && i < 2048; ++i) writeBox(w, boxes[i]);
}

inline Eigen::Isometry3d readTransform(FuzzReader& r) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  switch (r.u8() % 4) {
    case 0: break;
    case 1:  // 6 m from the origin, 4.8 m up, looking at it (z forward, x right, y down)
      T.linear() << 0, -0.6, 0.8, -1, 0, 0, 0, -0.8, -0.6;
      T.translation() << -3.6, 0.0, 4.8;
      break;
    case 2: {
      Eigen::Quaterniond q;
      q.x() = r.f64();
      q.y() = r.f64();
      q.z() = r.f64();
      q.w() = r.f64();
      const double n = q.norm();
      if (std::isfinite(n) && n > 0) q.coeffs() /= n;
      T.linear() = q.toRotationMatrix();
      for (int i = 0; i < 3; ++i) T.translation()[i] = r.f64();
      break;
    }
    default: T.matrix().setConstant(std::numeric_limits<double>::quiet_NaN()); break;
  }
  return T;
}
inline void writeTransform(FuzzWriter& w, const Eigen::Isometry3d& T) {
  w.u8(2);
  const Eigen::Quaterniond q(T.linear());
  w.f64(q.x());
  w.f64(q.y());
  w.f64(q.z());
  w.f64(q.w());
  for (int i = 0; i < 3; ++i) w.f64(T.translation()[i]);
}

}  // namespace detail

/// Decodes a fuzz input (never fails: missing bytes read as zeros).
inline FuzzSensorInput decodeSensorInput(const uint8_t* data, size_t size) {
  using namespace detail;
  FuzzReader r(data, size);
  FuzzSensorInput in;
  const uint8_t flags = r.u8();
  const int frames = std::min(3, (flags & 3) + 1);
  in.second_cycle = flags & 4;
  for (int f = 0; f < frames; ++f) {
    FuzzCamera c;
    readHeader(r, &c.msg.header);
    c.msg.camera = r.text(knownCameras());
    readInfo(r, &c.msg.color_info);
    readImage(r, &c.msg.depth);
    readInfo(r, &c.msg.depth_info);
    readBoxes(r, &c.msg.boxes);
    c.T_world_depth = readTransform(r);
    c.T_color_depth = readTransform(r);
    if (r.u8() & 1) {
      c.correction.offset = r.f64();
      c.correction.scale = r.f64();
    }
    in.cameras.push_back(std::move(c));
  }
  // After every frame (inputs written before the amplitude existed end here: no amplitude).
  for (FuzzCamera& c : in.cameras)
    if (r.u8() & 1) readImage(r, &c.msg.amplitude);
  return in;
}

/// Encodes cameras (at most 3) in the format decodeSensorInput reads.
inline std::vector<uint8_t> encodeSensorInput(const FuzzSensorInput& in) {
  using namespace detail;
  FuzzWriter w;
  const size_t n = std::min<size_t>(3, in.cameras.size());
  w.u8(static_cast<uint8_t>((n ? n - 1 : 0) | (in.second_cycle ? 4 : 0)));
  for (size_t f = 0; f < n; ++f) {
    const FuzzCamera& c = in.cameras[f];
    writeHeader(w, c.msg.header);
    w.text(c.msg.camera);
    writeInfo(w, c.msg.color_info);
    writeImage(w, c.msg.depth);
    writeInfo(w, c.msg.depth_info);
    writeBoxes(w, c.msg.boxes);
    writeTransform(w, c.T_world_depth);
    writeTransform(w, c.T_color_depth);
    const bool corr = !c.correction.isNone();
    w.u8(corr ? 1 : 0);
    if (corr) {
      w.f64(c.correction.offset);
      w.f64(c.correction.scale);
    }
  }
  for (size_t f = 0; f < n; ++f) {
    const sensor_msgs::Image& a = in.cameras[f].msg.amplitude;
    const bool has = a.width > 0 && a.height > 0;
    w.u8(has ? 1 : 0);
    if (has) writeImage(w, a);
  }
  return w.bytes();
}

/// A message the conversion refused, as the estimator would get it from a bag: the fields
/// converted one by one and the boxes as they are, even inverted or NaN (the estimator checks
/// them itself). Throws InputError for a depth encoding it cannot read.
inline SensorFrameData rawFrame(const SensorFrame& msg) {
  SensorFrameData f;
  f.camera = msg.camera;
  f.color_info = fromMsg(msg.color_info);
  f.depth_info = fromMsg(msg.depth_info);
  f.depth = depthFromMsg(msg.depth, msg.camera + " depth");
  try {  // as it came, even on another grid (the estimator checks it against the depth)
    f.amplitude = amplitudeFromMsg(boost::make_shared<sensor_msgs::Image>(msg.amplitude),
                                   msg.camera + " amplitude");
  } catch (const InputError&) {
    // an encoding no reader knows: the frame goes without amplitude
  }
  for (const PipeBox& b : msg.boxes) {
    DetectionBox d;
    d.label = b.label == PipeBox::PIN_END ? EndLabel::kPinEnd : EndLabel::kBoxEnd;
    d.confidence = b.confidence;
    d.x_min = b.x_min;
    d.y_min = b.y_min;
    d.x_max = b.x_max;
    d.y_max = b.y_max;
    f.boxes.push_back(d);
  }
  return f;
}

}  // namespace drill_pipe_pose::fuzz
