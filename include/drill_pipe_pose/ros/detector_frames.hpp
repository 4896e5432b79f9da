#pragma once
// The sensor node's frame assembly on ROS messages: kinect2_bridge-style colour, colour info,
// depth and depth info in, the SensorFrame the pipe_detector node publishes out
// (core/detector/frame_assembly.hpp does the work). The node calls detectorFrame; the offline
// tools (detect_bag on a recording, simulate_bag --detector-model on rendered frames) use
// OfflineDetector, which adds what the node gets from its parameters and from TF.

#include <geometry_msgs/TransformStamped.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "drill_pipe_pose/core/detector/detector_node_params.hpp"
#include "drill_pipe_pose/core/detector/frame_assembly.hpp"
#include "drill_pipe_pose/ros/tf_source.hpp"

namespace drill_pipe_pose {

/// How the node and detect_bag pair a camera's colour image, colour info, depth image and depth
/// info: message_filters' ApproximateTime on the capture stamps.
using DetectorSyncPolicy =
    message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                    sensor_msgs::Image, sensor_msgs::CameraInfo>;
using DetectorSync = message_filters::Synchronizer<DetectorSyncPolicy>;

/// A synchroniser of that pairing with the node's parameters queue_size (at least 5) and
/// sync_slop [s]; its inputs are connected (connectInput) or fed (add<i>) by the caller.
inline std::unique_ptr<DetectorSync> makeDetectorSync(int queue_size, double sync_slop) {
  auto sync = std::make_unique<DetectorSync>(DetectorSyncPolicy(std::max(queue_size, 5)));
  sync->setMaxIntervalDuration(ros::Duration(sync_slop));
  return sync;
}

/// The SensorFrame of one synchronised set of `camera`'s messages: stamped with the colour
/// image's capture time, frame ids and CameraInfos from the messages, the depth pixels shared
/// with `depth`; then detector::assembleSensorFrame (checks, boxes, crop). Throws InputError
/// naming the source (topic) and the field. `amplitude` (the driver's IR image of the same
/// capture, from `amplitude_source`), when given, goes along, cropped as the depth; one that
/// does not fit the depth is left out and the reason kept in amplitude_refused.
SensorFrameData detectorFrame(detector::YoloDetector& detector, const std::string& camera,
                              const sensor_msgs::ImageConstPtr& color,
                              const sensor_msgs::CameraInfo& color_info,
                              const sensor_msgs::ImageConstPtr& depth,
                              const sensor_msgs::CameraInfo& depth_info,
                              const Eigen::Isometry3d* T_color_depth,
                              const detector::FrameAssemblyOptions& options,
                              const detector::FrameSources& sources, cv::Mat* bgr = nullptr,
                              const sensor_msgs::ImageConstPtr& amplitude = nullptr,
                              const std::string& amplitude_source = "amplitude");

/// The pipe_detector node without ROS transport, for every camera of a recording: one detector
/// (the node's parameters, the same defaults), colour -> depth transforms from the recording's
/// TF (as the node looks them up), the node's capture-time rate limit per camera.
class OfflineDetector {
 public:
  /// Loads the model (InputError naming the file). `p.camera` is ignored: frames name theirs.
  /// model "" is `default_model` (the package's models/detector/pipe_yolo.onnx).
  OfflineDetector(const PipeDetectorNodeConfig& p, const std::string& default_model);

  /// A transform of the recording's /tf_static (is_static) or /tf.
  void addTf(const geometry_msgs::TransformStamped& t, bool is_static);

  /// The node's SensorFrame for one synchronised set, or nothing when max_rate skips it. Topics
  /// in errors are kinect2_bridge's under `prefix`. With crop_depth and no TF colour <- depth,
  /// the depth stays full (as in the node) and the camera is listed in camerasWithoutTf().
  /// `amplitude`: the IR image of the same capture (null: none), as the node's amplitude_topic.
  std::optional<SensorFrameData> process(const std::string& camera,
                                         const sensor_msgs::ImageConstPtr& color,
                                         const sensor_msgs::CameraInfo& color_info,
                                         const sensor_msgs::ImageConstPtr& depth,
                                         const sensor_msgs::CameraInfo& depth_info,
                                         const std::string& prefix = "/",
                                         const sensor_msgs::ImageConstPtr& amplitude = nullptr);

  const PipeDetectorNodeConfig& params() const { return params_; }
  const detector::YoloDetector& detector() const { return detector_; }
  /// Cameras whose depth was sent full because TF had no colour <- depth transform.
  const std::set<std::string>& camerasWithoutTf() const { return no_tf_; }
  /// Frames assembled, boxes per label, detector time [ms] summed.
  size_t frames() const { return frames_; }
  size_t boxes(EndLabel label) const { return label == EndLabel::kBoxEnd ? box_ends_ : pin_ends_; }
  double detectorMs() const { return detector_ms_; }

 private:
  PipeDetectorNodeConfig params_;
  detector::YoloDetector detector_;
  detector::FrameAssemblyOptions options_;
  TfTransforms tf_;
  std::map<std::string, int64_t> last_stamp_ns_;  ///< per camera, for max_rate
  std::set<std::string> no_tf_;
  size_t frames_ = 0, box_ends_ = 0, pin_ends_ = 0;
  double detector_ms_ = 0.0;
};

}  // namespace drill_pipe_pose
