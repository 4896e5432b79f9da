#include "drill_pipe_pose/ros/conversions.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <utility>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

int64_t toNs(const ros::Time& t) {
  return static_cast<int64_t>(t.toNSec());
}
ros::Time fromNs(int64_t ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

CameraInfoData fromMsg(const sensor_msgs::CameraInfo& msg) {
  CameraInfoData c;
  c.frame_id = msg.header.frame_id;
  c.width = msg.width;
  c.height = msg.height;
  c.distortion_model = msg.distortion_model;
  c.D = msg.D;
  std::copy(msg.K.begin(), msg.K.end(), c.K.begin());
  std::copy(msg.R.begin(), msg.R.end(), c.R.begin());
  std::copy(msg.P.begin(), msg.P.end(), c.P.begin());
  c.binning_x = msg.binning_x;
  c.binning_y = msg.binning_y;
  c.roi.x_offset = msg.roi.x_offset;
  c.roi.y_offset = msg.roi.y_offset;
  c.roi.width = msg.roi.width;
  c.roi.height = msg.roi.height;
  return c;
}

sensor_msgs::CameraInfo toMsg(const CameraInfoData& c, int64_t stamp_ns) {
  sensor_msgs::CameraInfo m;
  m.header.stamp = fromNs(stamp_ns);
  m.header.frame_id = c.frame_id;
  m.width = c.width;
  m.height = c.height;
  m.distortion_model = c.distortion_model;
  m.D = c.D;
  std::copy(c.K.begin(), c.K.end(), m.K.begin());
  std::copy(c.R.begin(), c.R.end(), m.R.begin());
  std::copy(c.P.begin(), c.P.end(), m.P.begin());
  m.binning_x = c.binning_x;
  m.binning_y = c.binning_y;
  m.roi.x_offset = c.roi.x_offset;
  m.roi.y_offset = c.roi.y_offset;
  m.roi.width = c.roi.width;
  m.roi.height = c.roi.height;
  return m;
}

namespace {

DepthImage depthHeader(const sensor_msgs::Image& msg, const std::string& source) {
  DepthImage d;
  d.encoding = parseDepthEncoding(msg.encoding, source);
  if (msg.is_bigendian)
    fail(source, ": is_bigendian = 1 is not supported (publish little-endian depth)");
  d.width = msg.width;
  d.height = msg.height;
  d.step = msg.step;
  d.size = msg.data.size();
  return d;
}

}  // namespace

DepthImage depthFromMsg(const sensor_msgs::ImageConstPtr& msg, const std::string& source) {
  DepthImage d = depthHeader(*msg, source);
  // Aliasing: the deleter owns the message, so the pixels live as long as any copy of `d`.
  d.data = std::shared_ptr<const uint8_t>(msg->data.data(), [msg](const uint8_t*) {});
  return d;
}

DepthImage depthFromMsg(const sensor_msgs::Image& msg, const std::string& source) {
  DepthImage d = depthHeader(msg, source);
  auto buf = std::make_shared<std::vector<uint8_t>>(msg.data);
  d.data = std::shared_ptr<const uint8_t>(buf, buf->data());
  return d;
}

AmplitudeImage amplitudeFromMsg(const sensor_msgs::ImageConstPtr& msg, const std::string& source) {
  AmplitudeImage a;
  if (msg->width == 0 || msg->height == 0) return a;  // not available
  a.f32 = parseAmplitudeEncoding(msg->encoding, source);
  if (msg->is_bigendian)
    fail(source, ": is_bigendian = 1 is not supported (publish a little-endian amplitude)");
  a.width = msg->width;
  a.height = msg->height;
  a.step = msg->step;
  a.size = msg->data.size();
  a.data = std::shared_ptr<const uint8_t>(msg->data.data(), [msg](const uint8_t*) {});
  return a;
}

void attachAmplitude(const sensor_msgs::ImageConstPtr& amplitude, const std::string& source,
                     SensorFrameData* frame) {
  frame->amplitude = AmplitudeImage();
  frame->amplitude_refused.clear();
  if (!amplitude) return;
  try {
    const AmplitudeImage a = amplitudeFromMsg(amplitude, source);
    frame->amplitude_refused = amplitudeMismatch(a, frame->depth, source);
    if (frame->amplitude_refused.empty()) frame->amplitude = a;
  } catch (const InputError& e) {
    frame->amplitude_refused = std::string(e.what()) + ": amplitude ignored, depth used without it";
  }
}

sensor_msgs::Image toMsg(const AmplitudeImage& image, int64_t stamp_ns,
                         const std::string& frame_id) {
  sensor_msgs::Image m;
  if (image.empty()) return m;
  m.header.stamp = fromNs(stamp_ns);
  m.header.frame_id = frame_id;
  m.width = image.width;
  m.height = image.height;
  m.encoding = image.f32 ? "32FC1" : "16UC1";
  m.is_bigendian = 0;
  m.step = image.step;
  m.data.assign(image.data.get(), image.data.get() + image.size);
  return m;
}

sensor_msgs::Image toMsg(const DepthImage& image, int64_t stamp_ns, const std::string& frame_id) {
  sensor_msgs::Image m;
  m.header.stamp = fromNs(stamp_ns);
  m.header.frame_id = frame_id;
  m.width = image.width;
  m.height = image.height;
  m.encoding = depthEncodingName(image.encoding);
  m.is_bigendian = 0;
  m.step = image.step;
  m.data.assign(image.data.get(), image.data.get() + image.size);
  return m;
}

DetectionBox fromMsg(const PipeBox& msg, const std::string& source) {
  DetectionBox b;
  b.label = parseEndLabel(msg.label, source);
  b.confidence = msg.confidence;
  b.x_min = msg.x_min;
  b.y_min = msg.y_min;
  b.x_max = msg.x_max;
  b.y_max = msg.y_max;
  if (!std::isfinite(b.x_min) || !std::isfinite(b.y_min) || !std::isfinite(b.x_max) ||
      !std::isfinite(b.y_max) || b.x_min > b.x_max || b.y_min > b.y_max)
    fail(source, ": box (x_min, y_min, x_max, y_max) = (", b.x_min, ", ", b.y_min, ", ", b.x_max,
         ", ", b.y_max, ") is not a finite box with min <= max");
  return b;
}

PipeBox toMsg(const DetectionBox& b) {
  PipeBox m;
  m.label = labelName(b.label);
  m.confidence = b.confidence;
  m.x_min = b.x_min;
  m.y_min = b.y_min;
  m.x_max = b.x_max;
  m.y_max = b.y_max;
  return m;
}

SensorFrameData fromMsg(const SensorFrameConstPtr& msg, const InputLimits& limits) {
  if (msg->camera.empty())
    fail("SensorFrame (frame_id \"", msg->header.frame_id, "\"): field camera is empty");
  const std::string& cam = msg->camera;
  checkFrameLimits(cam, msg->depth.width, msg->depth.height, msg->color_info.width,
                   msg->color_info.height, msg->depth_info.width, msg->depth_info.height,
                   msg->boxes.size(), limits);
  SensorFrameData f;
  f.camera = cam;
  f.stamp_ns = toNs(msg->header.stamp);
  f.frame_id = msg->header.frame_id;
  f.color_info = fromMsg(msg->color_info);
  f.depth_info = fromMsg(msg->depth_info);
  f.depth_stamp_ns = toNs(msg->depth.header.stamp);
  f.depth_frame_id = msg->depth.header.frame_id;
  // Validate now so that a bad frame is rejected at the door with its camera's name.
  PinholeCamera::fromCameraInfo(f.color_info, cam + " color_info");
  const PinholeCamera depth_cam = PinholeCamera::fromCameraInfo(f.depth_info, cam + " depth_info");
  // Aliasing pointer into the SensorFrame: no copy of the depth pixels.
  const sensor_msgs::ImageConstPtr depth_ptr(msg, &msg->depth);
  f.depth = depthFromMsg(depth_ptr, cam + " depth");
  validateDepthImage(f.depth, depth_cam, cam + " depth");
  attachAmplitude(sensor_msgs::ImageConstPtr(msg, &msg->amplitude), cam + " amplitude", &f);
  f.boxes.reserve(msg->boxes.size());
  for (size_t i = 0; i < msg->boxes.size(); ++i)
    f.boxes.push_back(fromMsg(msg->boxes[i], cam + " boxes[" + std::to_string(i) + "]"));
  return f;
}

SensorFrame toMsg(const SensorFrameData& f) {
  SensorFrame m;
  m.header.stamp = fromNs(f.stamp_ns);
  m.header.frame_id = f.frame_id;
  m.camera = f.camera;
  m.color_info = toMsg(f.color_info, f.stamp_ns);
  m.depth_info = toMsg(f.depth_info, f.depth_stamp_ns);
  m.depth = toMsg(f.depth, f.depth_stamp_ns, f.depth_frame_id);
  for (const auto& b : f.boxes) m.boxes.push_back(toMsg(b));
  m.amplitude = toMsg(f.amplitude, f.depth_stamp_ns, f.depth_frame_id);
  return m;
}

SensorFrame upgrade(LegacySensorFrame old) {
  SensorFrame m;
  m.header = std::move(old.header);
  m.camera = std::move(old.camera);
  m.color_info = std::move(old.color_info);
  m.depth = std::move(old.depth);
  m.depth_info = std::move(old.depth_info);
  m.boxes = std::move(old.boxes);
  return m;  // amplitude: empty, not available
}

geometry_msgs::TransformStamped toTransformMsg(const Eigen::Isometry3d& T_parent_child,
                                               const std::string& parent, const std::string& child,
                                               const ros::Time& stamp) {
  geometry_msgs::TransformStamped t = tf2::eigenToTransform(T_parent_child);
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  return t;
}

void fillPipeEnd(const EndEstimate& e, PipeEnd* end) {
  end->pose.pose = tf2::toMsg(e.T_world_end);
  for (int i = 0; i < 36; ++i) end->pose.covariance[i] = e.covariance(i / 6, i % 6);
  end->residual = e.residual;
  end->points = static_cast<uint32_t>(e.points);
  end->cameras = e.cameras;
}

PipeEnds toPipeEndsMsg(const CycleOutput& out, const std::string& world_frame) {
  PipeEnds ends;
  ends.header.stamp = fromNs(out.cycle.stamp_ns);
  ends.header.frame_id = world_frame;
  for (int e = 0; e < kNumEnds; ++e) {
    const PublishedEnd& pub = out.ends[e];
    PipeEnd end;
    end.label = labelName(static_cast<EndLabel>(e));
    end.valid = pub.valid;
    end.age = ros::Duration(pub.age);
    end.message = pub.message;
    if (pub.valid) fillPipeEnd(pub.estimate, &end);
    ends.ends.push_back(end);
  }
  if (out.pin_in_box) {
    ends.pin_in_box.valid = true;
    ends.pin_in_box.axial_standoff = out.pin_in_box->axial_standoff;
    ends.pin_in_box.lateral_offset = out.pin_in_box->lateral_offset;
    ends.pin_in_box.axis_angle = out.pin_in_box->axis_angle;
  }
  return ends;
}

}  // namespace drill_pipe_pose
