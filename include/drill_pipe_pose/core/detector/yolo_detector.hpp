#pragma once
// The sensor-node detector: a YOLO network run through OpenCV's cv::dnn (Darknet .cfg + .weights,
// so the thesis's Tiny-YOLOv3 drops in unchanged, or ONNX) on a fixed region of interest of the
// colour image, letterboxed to the network input. ROS-free.
//
// Pixels: the full colour image, x right, y down; boxes come back in full-image pixels with the
// labels box_end / pin_end (docs/conventions.md).

#include <opencv2/core.hpp>

#include <memory>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/detector/yolo_decoding.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"

namespace drill_pipe_pose::detector {

/// Detector settings (the pipe_detector node reads them from private parameters of the same name).
struct DetectorConfig {
  /// Model file: `.onnx`, or Darknet `.weights` (then `darknet_cfg` is the `.cfg`; empty: the
  /// same path with `.cfg` instead of `.weights`).
  std::string model;
  std::string darknet_cfg;
  /// Class names in the model's class order. Every name must be box_end or pin_end, or "" /
  /// "ignore" for a model class whose detections are dropped. Must match the model's class count.
  std::vector<std::string> labels{"box_end", "pin_end"};
  OutputFormat format = OutputFormat::kAuto;
  /// [px] network input, multiples of 32: the kinect2 qHD colour image at its own scale (tool
  /// joints are ~10 px wide at 6 m; shrinking them loses them).
  int input_width = 960;
  int input_height = 544;              ///< [px]
  bool allow_upscale = false;          ///< enlarge a roi smaller than the input (false: pad only)
  float confidence_threshold = 0.25f;  ///< minimum objectness x class probability
  float nms_threshold = 0.45f;         ///< IoU above which a same-class box is suppressed
  /// Candidates kept (the highest scores) before NMS: bounds its quadratic cost on an image that
  /// lights up everywhere (noise, glare), where thousands of cells pass the threshold.
  int max_candidates = 1000;
  /// IoU above which a box of the OTHER class is suppressed too (one tool joint, one label); >= 1
  /// disables it.
  float cross_class_nms_threshold = 0.7f;
  int max_boxes_per_class = 1;  ///< <= 0: no limit (the thesis kept the best box per class)
  /// Region of interest of the full colour image [px] (the work zone); width == height == 0: the
  /// whole image. It must lie inside the image (checked per frame).
  ImageRoi roi;
  bool swap_rb = true;  ///< the network expects RGB (the repository's models do)
  int num_threads = 1;  ///< cv::setNumThreads for inference (the sensor node's budget: one core)
};

/// Reads a labels file: one class name per line, in model order; blank lines and lines starting
/// with '#' are skipped. Throws InputError naming the file.
std::vector<std::string> readLabelsFile(const std::string& path);

/// Wraps pixel data of a ROS-style colour image without copying (converting only when needed) and
/// returns a BGR8 image. Encodings: bgr8, rgb8, bgra8, rgba8, mono8. Throws InputError naming
/// `source` and the field for an unsupported encoding or inconsistent width/height/step/size.
cv::Mat colorImageToBgr(const std::string& encoding, uint32_t width, uint32_t height, uint32_t step,
                        const uint8_t* data, size_t size, const std::string& source);

/// Checks that a colour and a depth frame id belong to the same sensor: when both end in the
/// kinect2_bridge suffixes (`_rgb_optical_frame` / `_ir_optical_frame`, `_link`), their base
/// names must agree, and with a non-empty `camera` equal it. Throws InputError naming both topics
/// and frame ids.
void checkSameCamera(const std::string& camera, const std::string& color_frame,
                     const std::string& color_topic, const std::string& depth_frame,
                     const std::string& depth_topic);

/// Checks that roi lies inside an image of width x height [px]; throws InputError naming `source`
/// ("parameter ~roi") and the values.
void checkRoi(const ImageRoi& roi, uint32_t width, uint32_t height, const std::string& source);

/// Timings of the last detect() call [ms].
struct DetectorTiming {
  double preprocess_ms = 0, inference_ms = 0, postprocess_ms = 0;
  double total() const { return preprocess_ms + inference_ms + postprocess_ms; }
};

class YoloDetector {
 public:
  /// Loads the model and checks it with one forward pass: throws InputError naming the file for a
  /// missing / unreadable / unparsable model, and naming the model and the labels when the class
  /// count or the output shapes do not fit; naming the field for a bad configuration.
  explicit YoloDetector(const DetectorConfig& config);
  ~YoloDetector();
  YoloDetector(YoloDetector&&) noexcept;
  YoloDetector& operator=(YoloDetector&&) noexcept;

  /// Detections [full-image px] on a BGR8 image: roi -> letterbox -> network -> decode ->
  /// NMS -> top-k per class. Labels outside box_end / pin_end are dropped. Throws InputError when
  /// the roi does not fit the image.
  std::vector<DetectionBox> detect(const cv::Mat& bgr);

  /// As detect(), but scores/classes as the network gives them (class ids), before label mapping.
  std::vector<ScoredBox> detectRaw(const cv::Mat& bgr);

  const DetectorConfig& config() const { return config_; }
  const OutputLayout& layout() const { return layout_; }
  const DetectorTiming& lastTiming() const { return timing_; }
  /// The letterbox used for an image of width x height [px].
  Letterbox letterbox(int width, int height) const;

 private:
  struct Impl;
  DetectorConfig config_;
  OutputLayout layout_;
  DetectorTiming timing_;
  std::vector<int> class_to_label_;  ///< -1: ignored class, else EndLabel
  std::unique_ptr<Impl> impl_;
};

/// Draws boxes (box_end blue, pin_end magenta) with label and score, and the roi, on `bgr`.
void drawDetections(cv::Mat& bgr, const std::vector<DetectionBox>& boxes, const ImageRoi& roi);

}  // namespace drill_pipe_pose::detector
