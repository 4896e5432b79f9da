// pipe_detector: the sensor node's 2D detector. Subscribes to one camera's kinect2_bridge-style
// topics (QHD colour + info, SD depth + info; approximate sync on the CAPTURE stamps), runs a
// YOLO model through OpenCV's cv::dnn (core YoloDetector) and publishes one
// drill_pipe_pose/SensorFrame per colour frame on <cam>/sensor_frame, stamped with the colour
// image's capture time (never the publish time).
//
// Parameters (private): the table in core/detector/detector_node_params.hpp (docs/parameters.md lists it).
// Publishes <cam>/sensor_frame and ~debug_image (bgr8, annotated; only while subscribed).
#include <drill_pipe_pose/SensorFrame.h>
#include <message_filters/subscriber.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <deque>
#include <optional>

#include "drill_pipe_pose/core/detector/detector_node_params.hpp"
#include "drill_pipe_pose/core/detector/frame_assembly.hpp"
#include "drill_pipe_pose/core/detector/yolo_detector.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/frame_sync.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/detector_frames.hpp"
#include "drill_pipe_pose/ros/param_loader.hpp"

namespace drill_pipe_pose {
namespace {

using sensor_msgs::CameraInfo;
using sensor_msgs::CameraInfoConstPtr;
using sensor_msgs::Image;
using sensor_msgs::ImageConstPtr;

class PipeDetectorNode {
 public:
  PipeDetectorNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh), tf_(tf_buffer_) {
    PipeDetectorNodeConfig p;  // the parameter table: core/detector/detector_node_params.hpp
    loadRosParams(pnh, pipeDetectorParamTable(), &p);
    camera_ = p.camera;
    if (camera_.empty())
      fail("parameter ", pnh.resolveName("camera"),
           " is missing: the sensor node's name <cam> (topics <cam>/qhd/image_color_rect, ...)");
    roi_param_ = "parameter " + pnh.resolveName("roi");
    const detector::DetectorConfig c = detectorConfigFromParams(
        p, ros::package::getPath("drill_pipe_pose") + "/models/detector/pipe_yolo.onnx",
        roi_param_);
    options_.crop_depth = p.crop_depth;
    options_.crop = p.crop;
    const double slop = p.sync_slop;
    max_rate_ = p.max_rate;
    tf_timeout_ = ros::Duration(p.tf_timeout);
    const int queue = std::max(p.queue_size, 1);
    for (const auto& key : unknownRosParams(pnh, paramNames(pipeDetectorParamTable())))
      ROS_WARN("pipe_detector: parameter %s is not one of the node's parameters (misspelt?)",
               key.c_str());

    detector_.emplace(c);  // loads and checks the model: InputError names the file

    color_topic_ = nh_.resolveName(conventions::colorImageTopic(camera_));
    color_info_topic_ = nh_.resolveName(conventions::colorInfoTopic(camera_));
    depth_topic_ = nh_.resolveName(conventions::depthImageTopic(camera_));
    depth_info_topic_ = nh_.resolveName(conventions::depthInfoTopic(camera_));
    sources_ = {color_topic_, color_info_topic_, depth_topic_, depth_info_topic_, roi_param_};
    pub_ = nh_.advertise<SensorFrame>(conventions::sensorFrameTopic(camera_), 5);
    debug_pub_ = pnh_.advertise<Image>("debug_image", 1);
    color_sub_.subscribe(nh_, color_topic_, queue);
    color_info_sub_.subscribe(nh_, color_info_topic_, queue);
    depth_sub_.subscribe(nh_, depth_topic_, queue);
    depth_info_sub_.subscribe(nh_, depth_info_topic_, queue);
    sync_ = makeDetectorSync(queue, slop);
    sync_->connectInput(color_sub_, color_info_sub_, depth_sub_, depth_info_sub_);
    sync_->registerCallback(&PipeDetectorNode::onFrames, this);
    // The amplitude on its own subscription, matched by stamp when a frame is assembled: a
    // driver without it, or a stalled IR stream, never holds the depth back.
    if (!p.amplitude_topic.empty()) {
      amplitude_topic_ = nh_.resolveName(camera_ + "/" + p.amplitude_topic);
      amplitude_sub_ = nh_.subscribe<Image>(
          amplitude_topic_, 2 * queue + 2, [this](const ImageConstPtr& m) { onAmplitude(m); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    }

    const auto& l = detector_->layout();
    std::string labels;
    for (const auto& s : c.labels) labels += (labels.empty() ? "" : ", ") + s;
    ROS_INFO(
        "pipe_detector %s: model %s (%s output, %d classes: %s), input %dx%d, roi %s, "
        "confidence >= %.2f, NMS %.2f (cross-class %.2f), max %d box(es) per class, depth %s, "
        "sync slop %.3f s, max rate %s, %d thread(s); %s + %s + %s + %s (+ amplitude %s) -> "
        "%s",
        camera_.c_str(), c.model.c_str(), detector::outputFormatName(l.format), l.num_classes,
        labels.c_str(), c.input_width, c.input_height,
        c.roi.isFull() ? "whole image"
                       : (std::to_string(c.roi.x_offset) + "," + std::to_string(c.roi.y_offset) +
                          " " + std::to_string(c.roi.width) + "x" + std::to_string(c.roi.height))
                             .c_str(),
        c.confidence_threshold, c.nms_threshold, c.cross_class_nms_threshold, c.max_boxes_per_class,
        options_.crop_depth ? "cropped to the boxes" : "full", slop,
        max_rate_ > 0 ? (std::to_string(max_rate_) + " Hz").c_str() : "unlimited", c.num_threads,
        color_topic_.c_str(), color_info_topic_.c_str(), depth_topic_.c_str(),
        depth_info_topic_.c_str(),
        amplitude_topic_.empty() ? "none" : amplitude_topic_.c_str(), pub_.getTopic().c_str());
  }

 private:
  /// Amplitude images kept to be matched to their depth (a few frames of the driver's rate).
  static constexpr size_t kAmplitudeKept = 8;

  void onAmplitude(const ImageConstPtr& m) {
    amplitudes_.push_back(m);
    if (amplitudes_.size() > kAmplitudeKept) amplitudes_.pop_front();
  }

  /// The kept amplitude image stamped as `depth` (within 1 ms), or null. Unmatched after
  /// amplitude images have been seen, it says so (throttled): the frame goes without.
  ImageConstPtr amplitudeFor(const ImageConstPtr& depth) {
    if (amplitude_topic_.empty()) return nullptr;
    for (auto it = amplitudes_.rbegin(); it != amplitudes_.rend(); ++it)
      if (std::abs(((*it)->header.stamp - depth->header.stamp).toSec()) <= 1e-3) return *it;
    if (!amplitudes_.empty())
      ROS_WARN_THROTTLE(10.0,
                        "pipe_detector %s: no %s stamped %.3f s (the depth's; newest %.3f s): "
                        "frame sent without amplitude (throttled, 10 s)",
                        camera_.c_str(), amplitude_topic_.c_str(), depth->header.stamp.toSec(),
                        amplitudes_.back()->header.stamp.toSec());
    return nullptr;
  }

  void onFrames(const ImageConstPtr& color, const CameraInfoConstPtr& color_info,
                const ImageConstPtr& depth, const CameraInfoConstPtr& depth_info) {
    const ros::Time stamp = color->header.stamp;
    // On a capture-time grid shared by every sensor node (a limit counted from each node's own
    // last frame would scatter the cameras' frames over the slot).
    if (!takeFrameAtRate(static_cast<int64_t>(stamp.toNSec()),
                         static_cast<int64_t>(last_stamp_.toNSec()), max_rate_))
      return;
    if (stamp < last_stamp_) last_stamp_ = ros::Time();  // bag loop / clock jump back
    try {
      process(color, color_info, depth, depth_info);
      last_stamp_ = stamp;
    } catch (const InputError& e) {
      ROS_ERROR_THROTTLE(5.0, "pipe_detector %s: %s (frame dropped; throttled, 5 s)",
                         camera_.c_str(), e.what());
    } catch (const cv::Exception& e) {
      ROS_ERROR_THROTTLE(5.0, "pipe_detector %s: OpenCV: %s (frame dropped; throttled, 5 s)",
                         camera_.c_str(), e.what());
    }
  }

  /// The frame assembly shared with detect_bag (ros/detector_frames.hpp), then publishing.
  void process(const ImageConstPtr& color, const CameraInfoConstPtr& color_info,
               const ImageConstPtr& depth, const CameraInfoConstPtr& depth_info) {
    std::optional<Eigen::Isometry3d> T;
    if (options_.crop_depth) {
      T = colorFromDepth(color->header.frame_id, depth->header.frame_id);
      if (!T)
        ROS_WARN_THROTTLE(5.0,
                          "pipe_detector %s: no TF %s <- %s yet: sending the full depth "
                          "image (throttled, 5 s)",
                          camera_.c_str(), color->header.frame_id.c_str(),
                          depth->header.frame_id.c_str());
    }
    cv::Mat bgr;
    const SensorFrameData f =
        detectorFrame(*detector_, camera_, color, *color_info, depth, *depth_info,
                      T ? &*T : nullptr, options_, sources_, &bgr, amplitudeFor(depth),
                      amplitude_topic_);
    if (!f.amplitude_refused.empty())
      ROS_WARN_THROTTLE(10.0, "pipe_detector %s (throttled, 10 s)", f.amplitude_refused.c_str());
    const detector::DetectorTiming& t = detector_->lastTiming();
    ROS_DEBUG("pipe_detector %s: %zu boxes, %.1f ms (pre %.1f, net %.1f, post %.1f)",
              camera_.c_str(), f.boxes.size(), t.total(), t.preprocess_ms, t.inference_ms,
              t.postprocess_ms);
    pub_.publish(toMsg(f));

    if (debug_pub_.getNumSubscribers() > 0) {
      cv::Mat img = bgr.clone();
      detector::drawDetections(img, f.boxes, detector_->config().roi);
      Image m;
      m.header = color->header;
      m.width = static_cast<uint32_t>(img.cols);
      m.height = static_cast<uint32_t>(img.rows);
      m.encoding = "bgr8";
      m.step = static_cast<uint32_t>(img.cols * 3);
      m.data.assign(img.data, img.data + img.total() * 3);
      debug_pub_.publish(m);
    }
  }

  /// T_color_depth from TF (static in practice: cached once found).
  std::optional<Eigen::Isometry3d> colorFromDepth(const std::string& color_frame,
                                                  const std::string& depth_frame) {
    if (T_color_depth_ && cached_color_frame_ == color_frame && cached_depth_frame_ == depth_frame)
      return T_color_depth_;
    try {
      const geometry_msgs::TransformStamped tf =
          tf_buffer_.lookupTransform(color_frame, depth_frame, ros::Time(0), tf_timeout_);
      T_color_depth_ = tf2::transformToEigen(tf);
      cached_color_frame_ = color_frame;
      cached_depth_frame_ = depth_frame;
      return T_color_depth_;
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(5.0, "pipe_detector %s: TF %s <- %s: %s (throttled, 5 s)", camera_.c_str(),
                        color_frame.c_str(), depth_frame.c_str(), e.what());
      return std::nullopt;
    }
  }

  ros::NodeHandle nh_, pnh_;
  std::string camera_, roi_param_;
  std::string color_topic_, color_info_topic_, depth_topic_, depth_info_topic_;
  std::optional<detector::YoloDetector> detector_;
  detector::FrameAssemblyOptions options_;
  detector::FrameSources sources_;
  double max_rate_ = 0.0;
  ros::Time last_stamp_;
  ros::Duration tf_timeout_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_;
  std::optional<Eigen::Isometry3d> T_color_depth_;
  std::string cached_color_frame_, cached_depth_frame_;
  ros::Publisher pub_, debug_pub_;
  message_filters::Subscriber<Image> color_sub_, depth_sub_;
  message_filters::Subscriber<CameraInfo> color_info_sub_, depth_info_sub_;
  std::unique_ptr<DetectorSync> sync_;
  std::string amplitude_topic_;  ///< resolved; "" : none
  ros::Subscriber amplitude_sub_;
  std::deque<ImageConstPtr> amplitudes_;
};

}  // namespace
}  // namespace drill_pipe_pose

int main(int argc, char** argv) {
  ros::init(argc, argv, "pipe_detector");
  try {
    drill_pipe_pose::PipeDetectorNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const drill_pipe_pose::InputError& e) {
    ROS_FATAL("pipe_detector: %s", e.what());
    return 1;
  }
  return 0;
}
