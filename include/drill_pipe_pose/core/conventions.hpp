#pragma once
// The conventions that bind the parts together, written out in docs/conventions.md. Every topic,
// frame and label name used in code comes from here.

#include <string>

namespace drill_pipe_pose {

/// The two tool-joint classes. Labels on the wire are exactly "box_end" and "pin_end".
enum class EndLabel { kBoxEnd = 0, kPinEnd = 1 };
constexpr int kNumEnds = 2;

namespace conventions {

constexpr const char* kBoxEndLabel = "box_end";
constexpr const char* kPinEndLabel = "pin_end";
constexpr const char* kDefaultWorldFrame = "world";

/// kinect2_bridge-style per-camera topics and frames (`<cam>` = base_name).
inline std::string colorImageTopic(const std::string& cam) {
  return cam + "/qhd/image_color_rect";
}
inline std::string colorInfoTopic(const std::string& cam) {
  return cam + "/qhd/camera_info";
}
/// The HD (1920x1080) streams, which the rig calibration records (docs/calibration.md).
inline std::string hdColorImageTopic(const std::string& cam) {
  return cam + "/hd/image_color_rect";
}
inline std::string hdMonoImageTopic(const std::string& cam) {
  return cam + "/hd/image_mono_rect";
}
inline std::string hdInfoTopic(const std::string& cam) {
  return cam + "/hd/camera_info";
}
inline std::string depthImageTopic(const std::string& cam) {
  return cam + "/sd/image_depth_rect";
}
/// The driver's IR amplitude on the depth image's grid (kinect2_bridge), stamped as the depth.
inline std::string amplitudeImageTopic(const std::string& cam) {
  return cam + "/sd/image_ir_rect";
}
inline std::string depthInfoTopic(const std::string& cam) {
  return cam + "/sd/camera_info";
}
inline std::string sensorFrameTopic(const std::string& cam) {
  return cam + "/sensor_frame";
}
/// `<cam>_link` is identical to `<cam>_rgb_optical_frame` (kinect2_bridge, publish_tf:=true).
inline std::string linkFrame(const std::string& cam) {
  return cam + "_link";
}
inline std::string colorOpticalFrame(const std::string& cam) {
  return cam + "_rgb_optical_frame";
}
inline std::string depthOpticalFrame(const std::string& cam) {
  return cam + "_ir_optical_frame";
}

/// Estimator outputs (relative to the node namespace) and simulation ground truth.
inline std::string poseTopic(EndLabel e) {
  return std::string(e == EndLabel::kBoxEnd ? kBoxEndLabel : kPinEndLabel) + "/pose";
}
constexpr const char* kPipeEndsTopic = "pipe_ends";
/// Every end with its instance id and pipe type (PipeEndArray).
constexpr const char* kPipeEndTypesTopic = "pipe_end_types";
constexpr const char* kStatusTopic = "status";
/// The simulator's scored joints as rendered (evaluation.hpp, TrueJoint), once per bag.
constexpr const char* kGroundTruthJointsTopic = "/ground_truth/joints";
inline std::string groundTruthTopic(EndLabel e) {
  return std::string("/ground_truth/") + (e == EndLabel::kBoxEnd ? kBoxEndLabel : kPinEndLabel);
}

}  // namespace conventions

/// "box_end" / "pin_end".
inline const char* labelName(EndLabel e) {
  return e == EndLabel::kBoxEnd ? conventions::kBoxEndLabel : conventions::kPinEndLabel;
}

/// Parses a wire label; throws InputError naming `source` for anything but the two labels.
EndLabel parseEndLabel(const std::string& label, const std::string& source);

}  // namespace drill_pipe_pose
