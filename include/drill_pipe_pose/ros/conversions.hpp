#pragma once
// Conversions between ROS messages and the ROS-free core types. The only place that knows both.

#include <drill_pipe_pose/LegacySensorFrame.h>
#include <drill_pipe_pose/PipeBox.h>
#include <drill_pipe_pose/PipeEnds.h>
#include <drill_pipe_pose/SensorFrame.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/cycle_runner.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"

#include <Eigen/Geometry>
#include <boost/make_shared.hpp>
#include <string>
#include <utility>
#include <vector>

namespace drill_pipe_pose {

int64_t toNs(const ros::Time& t);
ros::Time fromNs(int64_t ns);

CameraInfoData fromMsg(const sensor_msgs::CameraInfo& msg);
/// header.stamp is set from stamp_ns, header.frame_id from info.frame_id.
sensor_msgs::CameraInfo toMsg(const CameraInfoData& info, int64_t stamp_ns);

/// Wraps the pixels of `msg` without copying; the returned image keeps `msg` alive. Throws
/// InputError naming `source` for an unsupported encoding or a big-endian image.
DepthImage depthFromMsg(const sensor_msgs::ImageConstPtr& msg, const std::string& source);
/// As above but copies the pixels (for messages not held by a shared pointer).
DepthImage depthFromMsg(const sensor_msgs::Image& msg, const std::string& source);
sensor_msgs::Image toMsg(const DepthImage& image, int64_t stamp_ns, const std::string& frame_id);

/// Wraps an amplitude image's pixels without copying (empty for a 0 x 0 image). Throws
/// InputError naming `source` for an unsupported encoding or a big-endian image.
AmplitudeImage amplitudeFromMsg(const sensor_msgs::ImageConstPtr& msg, const std::string& source);
/// Reads `amplitude` (null or 0 x 0: none) into frame->amplitude beside frame->depth (already
/// read). One that cannot be read there (encoding, big-endian, another size or crop, short data)
/// is left out and frame->amplitude_refused says why, naming `source`: the depth is used without
/// it. The pixels are shared with the message.
void attachAmplitude(const sensor_msgs::ImageConstPtr& amplitude, const std::string& source,
                     SensorFrameData* frame);
/// An empty image gives an empty message (width 0: not available).
sensor_msgs::Image toMsg(const AmplitudeImage& image, int64_t stamp_ns,
                         const std::string& frame_id);

DetectionBox fromMsg(const PipeBox& msg, const std::string& source);
PipeBox toMsg(const DetectionBox& box);

/// Converts and validates a SensorFrame: camera name present, sizes within `limits` (checked
/// first, before anything is allocated), both CameraInfos usable, depth encoding supported, depth
/// image consistent with its CameraInfo (size, roi, step), labels known. Throws InputError
/// naming the camera and the field. The depth pixels are shared, not copied.
SensorFrameData fromMsg(const SensorFrameConstPtr& msg, const InputLimits& limits = InputLimits());
SensorFrame toMsg(const SensorFrameData& frame);

/// A SensorFrame of the definition before the amplitude field, as a current one without
/// amplitude.
SensorFrame upgrade(LegacySensorFrame old);

/// The SensorFrame in `m` (a rosbag::MessageInstance or a topic_tools::ShapeShifter): the
/// current definition, or the one before the amplitude field (bags and publishers of older
/// versions; upgraded, no amplitude). Null when `m` holds neither (another type). Both are
/// told apart by their MD5 sum, as ROS does.
template <class Message>
SensorFrameConstPtr sensorFrameOf(const Message& m) {
  const std::string md5 = m.getMD5Sum();
  // The current definition straight from the message's own buffer (the node's per-frame path).
  if (md5 == ros::message_traits::md5sum<SensorFrame>())
    return m.template instantiate<SensorFrame>();
  if (md5 != ros::message_traits::md5sum<LegacySensorFrame>()) return nullptr;
  // The older definition from its bytes: a ShapeShifter's instantiate() also insists on the
  // type's name, and the older definition was published under the current one's.
  std::vector<uint8_t> buf(m.size());
  ros::serialization::OStream out(buf.data(), static_cast<uint32_t>(buf.size()));
  m.write(out);
  ros::serialization::IStream in(buf.data(), static_cast<uint32_t>(buf.size()));
  LegacySensorFrame old;
  ros::serialization::deserialize(in, old);
  return boost::make_shared<SensorFrame>(upgrade(std::move(old)));
}

/// The estimate's pose, covariance, residual, points and cameras into `end`.
void fillPipeEnd(const EndEstimate& e, PipeEnd* end);
/// One cycle's pipe_ends message as the pose_estimator node publishes it (bench_estimator
/// --poses-bag writes the same): every configured end, valid or not, and pin_in_box.
PipeEnds toPipeEndsMsg(const CycleOutput& out, const std::string& world_frame);

/// A transform message parent <- child (T_parent_child) stamped `stamp`.
geometry_msgs::TransformStamped toTransformMsg(const Eigen::Isometry3d& T_parent_child,
                                               const std::string& parent, const std::string& child,
                                               const ros::Time& stamp);

}  // namespace drill_pipe_pose
