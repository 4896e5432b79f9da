// The pipe_detector node's parameter table (detector_node_params.hpp): one line per parameter.

#include "drill_pipe_pose/core/detector/detector_node_params.hpp"

#include <cmath>

#include "drill_pipe_pose/core/detector/yolo_decoding.hpp"
#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

namespace {

using C = PipeDetectorNodeConfig;
#define P(key, field, unit, range, doc) DPP_PARAM(C, key, field, unit, range, doc)

ParamTable<C> makeTable() {
  return {
      P("camera", camera, "", anyValue(),
        "(required) sensor node name <cam>: topics <cam>/qhd/..., <cam>/sd/..., "
        "<cam>/sensor_frame"),
      P("model", detector.model, "", anyValue(),
        ".onnx or Darknet .weights; empty: the package's models/detector/pipe_yolo.onnx"),
      P("darknet_cfg", detector.darknet_cfg, "", anyValue(),
        "Darknet .cfg (empty: the model path with .cfg)"),
      P("labels", detector.labels, "", anyValue(),
        "class names in model order (box_end, pin_end or ignore)"),
      P("labels_file", labels_file, "", anyValue(),
        "one class name per line; overrides labels when set"),
      paramEnum<C>(
          "output_format", {"auto", "grid", "yolov5", "yolov8", "darknet"},
          "the network's output layout", [](auto& c) -> auto& { return c.detector.format; },
          [](detector::OutputFormat f) { return detector::outputFormatName(f); },
          [](const std::string& s) { return detector::parseOutputFormat(s, "output_format"); }),
      P("input_width", detector.input_width, "px", positive(),
        "network input width, a multiple of 32"),
      P("input_height", detector.input_height, "px", positive(),
        "network input height, a multiple of 32"),
      P("allow_upscale", detector.allow_upscale, "", anyValue(),
        "enlarge a roi smaller than the input (false: pad only)"),
      P("confidence_threshold", detector.confidence_threshold, "", atLeast(1e-6),
        "minimum objectness x class probability"),
      P("nms_threshold", detector.nms_threshold, "", atLeast(1e-6),
        "IoU above which a same-class box is suppressed"),
      P("cross_class_nms_threshold", detector.cross_class_nms_threshold, "", atLeast(0),
        "IoU above which a box of the other class is suppressed too; >= 1: off"),
      P("max_candidates", detector.max_candidates, "", atLeast(1), "boxes kept before NMS"),
      P("max_boxes_per_class", detector.max_boxes_per_class, "", anyValue(),
        "boxes kept per class; <= 0: unlimited"),
      P("num_threads", detector.num_threads, "", anyValue(), "OpenCV threads for inference"),
      P("roi", roi, "px", atLeast(0),
        "[x, y, width, height] of the colour image to run on; []: the whole image"),
      P("crop_depth", crop_depth, "", anyValue(),
        "send depth cropped to the boxes' frustum (depth_info.roi)"),
      P("crop_margin_px", crop.margin_px, "px", atLeast(0), "boxes grown by this for the crop"),
      P("crop_min_range", crop.min_range, "m", atLeast(0),
        "nearest depth a box pixel can have (crop)"),
      P("crop_max_range", crop.max_range, "m", atLeast(0),
        "farthest depth a box pixel can have (crop)"),
      P("sync_slop", sync_slop, "s", atLeast(0), "max colour/depth capture-stamp difference"),
      P("amplitude_topic", amplitude_topic, "", anyValue(),
        "the driver's IR amplitude on the depth grid, under <cam>/ (kinect2_bridge: "
        "sd/image_ir_rect); matched to the depth by stamp, sent in the SensorFrame; \"\": none"),
      P("queue_size", queue_size, "", anyValue(),
        "per-topic subscriber queue (small: always the latest frame; < 1 is 1)"),
      P("max_rate", max_rate, "Hz", atLeast(0),
        "process at most this many frames per second of capture time (first of each slot); "
        "0: all"),
      P("tf_timeout", tf_timeout, "s", atLeast(0),
        "wait for <cam>_rgb_optical_frame <- <cam>_ir_optical_frame"),
  };
}
#undef P

}  // namespace

const ParamTable<PipeDetectorNodeConfig>& pipeDetectorParamTable() {
  static const ParamTable<PipeDetectorNodeConfig> table = makeTable();
  return table;
}

detector::DetectorConfig detectorConfigFromParams(const PipeDetectorNodeConfig& p,
                                                  const std::string& default_model,
                                                  const std::string& roi_source) {
  detector::DetectorConfig c = p.detector;
  if (c.model.empty()) c.model = default_model;
  if (!p.labels_file.empty()) c.labels = detector::readLabelsFile(p.labels_file);
  const std::vector<double>& roi = p.roi;
  if (roi.empty()) return c;
  if (roi.size() != 4)
    fail(roi_source, ": expected [x, y, width, height] in colour pixels (or [] for the whole image), got ",
         roi.size(), " numbers");
  for (size_t i = 0; i < 4; ++i)
    if (!(roi[i] >= 0.0) || roi[i] != std::floor(roi[i]))
      fail(roi_source, "[", i, "] = ", roi[i], ": must be a non-negative integer");
  c.roi.x_offset = static_cast<uint32_t>(roi[0]);
  c.roi.y_offset = static_cast<uint32_t>(roi[1]);
  c.roi.width = static_cast<uint32_t>(roi[2]);
  c.roi.height = static_cast<uint32_t>(roi[3]);
  if (c.roi.width == 0 || c.roi.height == 0)
    fail(roi_source, " = [", roi[0], ", ", roi[1], ", ", roi[2], ", ", roi[3],
         "]: width and height must be > 0");
  return c;
}

std::string pipeDetectorParamsMarkdown() {
  return paramTableMarkdown(pipeDetectorParamTable());
}

}  // namespace drill_pipe_pose
