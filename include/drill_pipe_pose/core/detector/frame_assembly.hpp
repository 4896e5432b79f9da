#pragma once
// The sensor node's frame assembly, ROS-free: one camera's colour image and depth frame in, the
// SensorFrame it publishes out (checks, YOLO boxes, depth cropped to the boxes). The
// pipe_detector node, detect_bag and simulate_bag --detector-model all call it (through
// ros/detector_frames.hpp), so that offline runs give the node's frames.

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/detector/yolo_detector.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"

namespace drill_pipe_pose::detector {

/// What the inputs are called in error messages (the node: its resolved topics; detect_bag: the
/// bag's topics; roi: "parameter ~roi").
struct FrameSources {
  std::string color = "colour image", color_info = "colour camera_info";
  std::string depth = "depth image", depth_info = "depth camera_info";
  std::string roi = "roi";
};

/// The topics of `camera` (kinect2_bridge naming, docs/conventions.md) as FrameSources, each
/// prefixed with `prefix` (e.g. "/" or a resolved namespace).
FrameSources kinectSources(const std::string& camera, const std::string& prefix = "/");

/// A ROS-style colour image's pixels (not owned): encoding bgr8, rgb8, bgra8, rgba8 or mono8.
struct ColorPixels {
  std::string encoding;
  uint32_t width = 0, height = 0, step = 0;
  const uint8_t* data = nullptr;
  size_t size = 0;
};

/// What the node does with the boxes besides sending them.
struct FrameAssemblyOptions {
  bool crop_depth = false;  ///< depth cropped to the boxes' frustum (cropDepthToBoxes)
  DepthCropConfig crop;
};

/// The SensorFrame of one colour + depth pair: `frame` carries everything but the boxes (camera,
/// capture stamps, frame ids, both CameraInfos, the depth image). Checks that colour and depth
/// come from the same sensor (checkSameCamera), that each CameraInfo's frame id is its image's,
/// that the colour image has its CameraInfo's size, the depth image its CameraInfo's (roi-aware)
/// and the roi lies inside the colour image; then runs the detector and, with crop_depth and a
/// known T_color_depth (colour optical frame <- depth optical frame), crops the depth to the
/// boxes. Without T_color_depth the depth stays full (the node warns). Throws InputError naming
/// the source (topic) and the field; cv::Exception from OpenCV. `bgr` (optional) receives the
/// colour image as the network saw it (BGR8; it may share `color`'s pixels).
SensorFrameData assembleSensorFrame(YoloDetector& detector, SensorFrameData frame,
                                    const ColorPixels& color,
                                    const Eigen::Isometry3d* T_color_depth,
                                    const FrameAssemblyOptions& options,
                                    const FrameSources& sources, cv::Mat* bgr = nullptr);

}  // namespace drill_pipe_pose::detector
