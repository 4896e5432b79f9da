// The sensor node's frame assembly on ROS messages (detector_frames.hpp).

#include "drill_pipe_pose/ros/detector_frames.hpp"

#include <tf2/exceptions.h>

#include "drill_pipe_pose/core/frame_sync.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"

namespace drill_pipe_pose {

SensorFrameData detectorFrame(detector::YoloDetector& detector, const std::string& camera,
                              const sensor_msgs::ImageConstPtr& color,
                              const sensor_msgs::CameraInfo& color_info,
                              const sensor_msgs::ImageConstPtr& depth,
                              const sensor_msgs::CameraInfo& depth_info,
                              const Eigen::Isometry3d* T_color_depth,
                              const detector::FrameAssemblyOptions& options,
                              const detector::FrameSources& sources, cv::Mat* bgr,
                              const sensor_msgs::ImageConstPtr& amplitude,
                              const std::string& amplitude_source) {
  SensorFrameData f;
  f.camera = camera;
  f.stamp_ns = toNs(color->header.stamp);
  f.frame_id = color->header.frame_id;
  f.color_info = fromMsg(color_info);
  f.depth_info = fromMsg(depth_info);
  f.depth_stamp_ns = toNs(depth->header.stamp);
  f.depth_frame_id = depth->header.frame_id;
  f.depth = depthFromMsg(depth, sources.depth);
  attachAmplitude(amplitude, amplitude_source, &f);
  detector::ColorPixels pixels;
  pixels.encoding = color->encoding;
  pixels.width = color->width;
  pixels.height = color->height;
  pixels.step = color->step;
  pixels.data = color->data.data();
  pixels.size = color->data.size();
  return detector::assembleSensorFrame(detector, std::move(f), pixels, T_color_depth, options,
                                       sources, bgr);
}

OfflineDetector::OfflineDetector(const PipeDetectorNodeConfig& p,
                                 const std::string& default_model)
    : params_(p), detector_(detectorConfigFromParams(p, default_model, "parameter roi")) {
  options_.crop_depth = p.crop_depth;
  options_.crop = p.crop;
}

void OfflineDetector::addTf(const geometry_msgs::TransformStamped& t, bool is_static) {
  tf_.add(t, is_static);
}

std::optional<SensorFrameData> OfflineDetector::process(
    const std::string& camera, const sensor_msgs::ImageConstPtr& color,
    const sensor_msgs::CameraInfo& color_info, const sensor_msgs::ImageConstPtr& depth,
    const sensor_msgs::CameraInfo& depth_info, const std::string& prefix,
    const sensor_msgs::ImageConstPtr& amplitude) {
  const int64_t stamp = toNs(color->header.stamp);
  auto last = last_stamp_ns_.find(camera);
  const int64_t last_ns = last == last_stamp_ns_.end() ? 0 : last->second;
  if (!takeFrameAtRate(stamp, last_ns, params_.max_rate)) return std::nullopt;
  std::optional<Eigen::Isometry3d> T;
  if (options_.crop_depth) {
    try {
      T = tf_.lookup(color->header.frame_id, depth->header.frame_id, stamp);
    } catch (const tf2::TransformException&) {
      no_tf_.insert(camera);
    }
  }
  detector::FrameSources sources = detector::kinectSources(camera, prefix);
  sources.roi = "parameter roi";
  SensorFrameData f =
      detectorFrame(detector_, camera, color, color_info, depth, depth_info, T ? &*T : nullptr,
                    options_, sources, nullptr, amplitude,
                    prefix + conventions::amplitudeImageTopic(camera));
  last_stamp_ns_[camera] = stamp;
  ++frames_;
  for (const DetectionBox& b : f.boxes) ++(b.label == EndLabel::kBoxEnd ? box_ends_ : pin_ends_);
  detector_ms_ += detector_.lastTiming().total();
  return f;
}

}  // namespace drill_pipe_pose
