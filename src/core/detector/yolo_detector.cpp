#include "drill_pipe_pose/core/detector/yolo_detector.hpp"

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <fstream>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose::detector {

namespace {

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void checkReadable(const std::string& path, const std::string& what) {
  if (path.empty()) fail(what, ": no file given");
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(what, " '", path, "' does not exist or cannot be read");
  char c;
  if (!f.get(c)) fail(what, " '", path, "' is empty");
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// Base name of a frame id following kinect2_bridge's naming, or "" when it does not.
std::string sensorBase(const std::string& frame) {
  std::string f = frame;
  if (!f.empty() && f.front() == '/') f.erase(0, 1);
  for (const char* suffix : {"_rgb_optical_frame", "_ir_optical_frame", "_link"})
    if (endsWith(f, suffix)) return f.substr(0, f.size() - std::char_traits<char>::length(suffix));
  return "";
}

}  // namespace

std::vector<std::string> readLabelsFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail("labels file '", path, "' does not exist or cannot be read");
  std::vector<std::string> labels;
  std::string line;
  while (std::getline(f, line)) {
    const auto b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos || line[b] == '#') continue;
    const auto e = line.find_last_not_of(" \t\r");
    labels.push_back(line.substr(b, e - b + 1));
  }
  if (labels.empty()) fail("labels file '", path, "' lists no class");
  return labels;
}

cv::Mat colorImageToBgr(const std::string& encoding, uint32_t width, uint32_t height, uint32_t step,
                        const uint8_t* data, size_t size, const std::string& source) {
  int channels = 0;
  if (encoding == "bgr8" || encoding == "rgb8")
    channels = 3;
  else if (encoding == "bgra8" || encoding == "rgba8")
    channels = 4;
  else if (encoding == "mono8")
    channels = 1;
  else
    fail(source, ": encoding '", encoding,
         "' is not supported by the detector (expected bgr8, rgb8, bgra8, rgba8 or mono8)");
  if (width == 0 || height == 0) fail(source, ": empty image (", width, " x ", height, ")");
  if (step < width * channels)
    fail(source, ": step ", step, " < width ", width, " x ", channels, " bytes per pixel");
  if (size < static_cast<size_t>(step) * height)
    fail(source, ": data holds ", size, " bytes, step x height needs ",
         static_cast<size_t>(step) * height);
  cv::Mat wrap(static_cast<int>(height), static_cast<int>(width), CV_8UC(channels),
               const_cast<uint8_t*>(data), step);
  if (encoding == "bgr8") return wrap;
  cv::Mat out;
  if (encoding == "rgb8")
    cv::cvtColor(wrap, out, cv::COLOR_RGB2BGR);
  else if (encoding == "bgra8")
    cv::cvtColor(wrap, out, cv::COLOR_BGRA2BGR);
  else if (encoding == "rgba8")
    cv::cvtColor(wrap, out, cv::COLOR_RGBA2BGR);
  else
    cv::cvtColor(wrap, out, cv::COLOR_GRAY2BGR);
  return out;
}

void checkSameCamera(const std::string& camera, const std::string& color_frame,
                     const std::string& color_topic, const std::string& depth_frame,
                     const std::string& depth_topic) {
  if (color_frame.empty()) fail(color_topic, ": header.frame_id is empty");
  if (depth_frame.empty()) fail(depth_topic, ": header.frame_id is empty");
  const std::string cb = sensorBase(color_frame), db = sensorBase(depth_frame);
  if (!cb.empty() && !db.empty() && cb != db)
    fail("colour and depth come from different cameras: ", color_topic, " has frame_id '",
         color_frame, "', ", depth_topic, " has frame_id '", depth_frame, "'");
  if (!camera.empty() && !cb.empty() && cb != camera)
    fail(color_topic, ": frame_id '", color_frame, "' belongs to camera '", cb,
         "', but this detector is configured for camera '", camera, "'");
  if (!camera.empty() && !db.empty() && db != camera)
    fail(depth_topic, ": frame_id '", depth_frame, "' belongs to camera '", db,
         "', but this detector is configured for camera '", camera, "'");
}

void checkRoi(const ImageRoi& roi, uint32_t width, uint32_t height, const std::string& source) {
  if (roi.isFull()) return;
  if (roi.width == 0 || roi.height == 0)
    fail(source, " = [", roi.x_offset, ", ", roi.y_offset, ", ", roi.width, ", ", roi.height,
         "]: width and height must be > 0 (or all four 0 for the whole image)");
  if (static_cast<uint64_t>(roi.x_offset) + roi.width > width ||
      static_cast<uint64_t>(roi.y_offset) + roi.height > height)
    fail(source, " = [", roi.x_offset, ", ", roi.y_offset, ", ", roi.width, ", ", roi.height,
         "] (x, y, width, height) lies outside the ", width, " x ", height, " colour image");
}

struct YoloDetector::Impl {
  cv::dnn::Net net;
  std::vector<std::string> out_names;
  std::string source;  ///< "model '<path>'" for errors
  cv::Mat blob;
  std::vector<cv::Mat> outs;

  std::vector<OutputBlob> forward(const cv::Mat& input_blob) {
    net.setInput(input_blob);
    outs.clear();
    net.forward(outs, out_names);
    std::vector<OutputBlob> blobs;
    for (const cv::Mat& m : outs) {
      OutputBlob b;
      b.dims.assign(m.size.p, m.size.p + m.dims);
      b.data = reinterpret_cast<const float*>(m.data);
      blobs.push_back(b);
    }
    return blobs;
  }
};

YoloDetector::YoloDetector(const DetectorConfig& config) : config_(config), impl_(new Impl) {
  const DetectorConfig& c = config_;
  if (c.input_width <= 0 || c.input_width % 32 != 0)
    fail("detector input_width = ", c.input_width, ": must be a positive multiple of 32");
  if (c.input_height <= 0 || c.input_height % 32 != 0)
    fail("detector input_height = ", c.input_height, ": must be a positive multiple of 32");
  if (!(c.confidence_threshold > 0.0f && c.confidence_threshold <= 1.0f))
    fail("detector confidence_threshold = ", c.confidence_threshold, ": must be in (0, 1]");
  if (c.max_candidates < 1)
    fail("detector max_candidates = ", c.max_candidates, ": must be >= 1");
  if (!(c.nms_threshold > 0.0f && c.nms_threshold <= 1.0f))
    fail("detector nms_threshold = ", c.nms_threshold, ": must be in (0, 1]");
  if (c.labels.empty()) fail("detector labels: empty list (expected e.g. [box_end, pin_end])");
  for (size_t i = 0; i < c.labels.size(); ++i) {
    const std::string& l = c.labels[i];
    if (l == conventions::kBoxEndLabel)
      class_to_label_.push_back(int(EndLabel::kBoxEnd));
    else if (l == conventions::kPinEndLabel)
      class_to_label_.push_back(int(EndLabel::kPinEnd));
    else if (l.empty() || l == "ignore")
      class_to_label_.push_back(-1);
    else
      fail("detector labels[", i, "] = '", l, "': expected box_end, pin_end, or ignore");
  }
  impl_->source = "model '" + c.model + "'";

  // Load.
  if (endsWith(c.model, ".onnx")) {
    checkReadable(c.model, "model file");
    try {
      impl_->net = cv::dnn::readNetFromONNX(c.model);
    } catch (const cv::Exception& e) {
      fail("model file '", c.model, "': OpenCV ", CV_VERSION,
           " cannot read it as ONNX: ", e.what());
    }
  } else if (endsWith(c.model, ".weights")) {
    std::string cfg = c.darknet_cfg;
    if (cfg.empty()) cfg = c.model.substr(0, c.model.size() - 8) + ".cfg";
    checkReadable(cfg, "Darknet configuration file");
    checkReadable(c.model, "Darknet weights file");
    try {
      impl_->net = cv::dnn::readNetFromDarknet(cfg, c.model);
    } catch (const cv::Exception& e) {
      fail("Darknet model '", cfg, "' + '", c.model, "': OpenCV cannot read it: ", e.what());
    }
    impl_->source = "Darknet model '" + cfg + "' + '" + c.model + "'";
  } else {
    fail("model file '", c.model,
         "': unknown model format (expected an .onnx file or Darknet .weights with its .cfg)");
  }
  if (impl_->net.empty()) fail(impl_->source, ": OpenCV loaded an empty network");
  impl_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  impl_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  impl_->out_names = impl_->net.getUnconnectedOutLayersNames();
  if (c.num_threads > 0) cv::setNumThreads(c.num_threads);

  // One forward pass at the configured input size: output shapes -> layout and class count.
  std::vector<OutputBlob> outs;
  try {
    const cv::Mat zeros(c.input_height, c.input_width, CV_8UC3, cv::Scalar(114, 114, 114));
    outs = impl_->forward(
        cv::dnn::blobFromImage(zeros, 1.0 / 255.0, cv::Size(), cv::Scalar(), c.swap_rb, false));
  } catch (const cv::Exception& e) {
    fail(impl_->source, ": forward pass at input ", c.input_width, " x ", c.input_height,
         " failed: ", e.what());
  }
  layout_ = guessOutputLayout(outs, c.format, impl_->source);
  if (layout_.num_classes != static_cast<int>(c.labels.size()))
    fail(impl_->source, " has ", layout_.num_classes, " classes (",
         outputFormatName(layout_.format), " output), but ", c.labels.size(),
         " labels are configured: the labels must list the "
         "model's classes in order");
}

YoloDetector::~YoloDetector() = default;
YoloDetector::YoloDetector(YoloDetector&&) noexcept = default;
YoloDetector& YoloDetector::operator=(YoloDetector&&) noexcept = default;

Letterbox YoloDetector::letterbox(int width, int height) const {
  const ImageRoi& r = config_.roi;
  if (r.isFull())
    return Letterbox::compute(0, 0, width, height, config_.input_width, config_.input_height,
                              config_.allow_upscale);
  return Letterbox::compute(static_cast<int>(r.x_offset), static_cast<int>(r.y_offset),
                            static_cast<int>(r.width), static_cast<int>(r.height),
                            config_.input_width, config_.input_height, config_.allow_upscale);
}

std::vector<ScoredBox> YoloDetector::detectRaw(const cv::Mat& bgr) {
  const auto t0 = std::chrono::steady_clock::now();
  if (bgr.empty() || bgr.type() != CV_8UC3)
    fail("detector: expected a non-empty BGR8 image (CV_8UC3), got type ", bgr.type());
  checkRoi(config_.roi, static_cast<uint32_t>(bgr.cols), static_cast<uint32_t>(bgr.rows),
           "detector roi");
  const Letterbox lb = letterbox(bgr.cols, bgr.rows);
  const cv::Mat roi = bgr(cv::Rect(lb.roi_x, lb.roi_y, lb.roi_width, lb.roi_height));
  cv::Mat input(config_.input_height, config_.input_width, CV_8UC3, cv::Scalar(114, 114, 114));
  cv::Mat dst = input(cv::Rect(lb.pad_x, lb.pad_y, lb.resized_width, lb.resized_height));
  if (lb.resized_width == lb.roi_width && lb.resized_height == lb.roi_height)
    roi.copyTo(dst);
  else
    cv::resize(roi, dst, dst.size(), 0, 0, lb.scale < 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR);
  cv::dnn::blobFromImage(input, impl_->blob, 1.0 / 255.0, cv::Size(), cv::Scalar(), config_.swap_rb,
                         false);
  timing_.preprocess_ms = msSince(t0);

  const auto t1 = std::chrono::steady_clock::now();
  const std::vector<OutputBlob> outs = impl_->forward(impl_->blob);
  timing_.inference_ms = msSince(t1);

  const auto t2 = std::chrono::steady_clock::now();
  std::vector<ScoredBox> boxes = decodeOutputs(outs, layout_, config_.input_width,
                                               config_.input_height, config_.confidence_threshold);
  PostprocessConfig post;
  post.max_candidates = config_.max_candidates;
  post.nms_threshold = config_.nms_threshold;
  post.cross_class_nms_threshold = config_.cross_class_nms_threshold;
  post.max_boxes_per_class = config_.max_boxes_per_class;
  boxes = postprocessBoxes(std::move(boxes), lb, post);
  timing_.postprocess_ms = msSince(t2);
  return boxes;
}

std::vector<DetectionBox> YoloDetector::detect(const cv::Mat& bgr) {
  std::vector<DetectionBox> out;
  for (const ScoredBox& b : detectRaw(bgr)) {
    const int label = class_to_label_[static_cast<size_t>(b.class_id)];
    if (label < 0) continue;
    DetectionBox d;
    d.label = static_cast<EndLabel>(label);
    d.confidence = b.score;
    d.x_min = b.x_min;
    d.y_min = b.y_min;
    d.x_max = b.x_max;
    d.y_max = b.y_max;
    out.push_back(d);
  }
  return out;
}

void drawDetections(cv::Mat& bgr, const std::vector<DetectionBox>& boxes, const ImageRoi& roi) {
  if (!roi.isFull())
    cv::rectangle(bgr, cv::Rect(roi.x_offset, roi.y_offset, roi.width, roi.height),
                  cv::Scalar(0, 255, 0), 1);
  for (const DetectionBox& b : boxes) {
    const cv::Scalar colour =
        b.label == EndLabel::kBoxEnd ? cv::Scalar(255, 64, 0) : cv::Scalar(255, 0, 255);
    cv::rectangle(bgr, cv::Point(cvRound(b.x_min), cvRound(b.y_min)),
                  cv::Point(cvRound(b.x_max), cvRound(b.y_max)), colour, 1);
    const std::string text = std::string(labelName(b.label)) + " " +
                             std::to_string(int(std::lround(b.confidence * 100)));
    cv::putText(bgr, text, cv::Point(cvRound(b.x_min), std::max(10, cvRound(b.y_min) - 3)),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, colour, 1);
  }
}

}  // namespace drill_pipe_pose::detector
