#pragma once
// The pipe_detector node's parameter table (core/param_table.hpp): what the node reads, with
// defaults in the struct below (and in detector::DetectorConfig / DepthCropConfig). The node's
// loader and the pipe_detector table of docs/parameters.md (checked by a test) come from it.

#include <string>
#include <vector>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/detector/yolo_detector.hpp"
#include "drill_pipe_pose/core/param_table.hpp"

namespace drill_pipe_pose {

struct PipeDetectorNodeConfig {
  std::string camera;  ///< required: <cam> of the topics
  /// The network. model "" (default) is the package's models/detector/pipe_yolo.onnx.
  detector::DetectorConfig detector;
  std::string labels_file;  ///< one class name per line; overrides detector.labels when set
  std::vector<double> roi;  ///< [x, y, width, height] of the colour image [px]; empty: whole
  bool crop_depth = false;  ///< send depth cropped to the boxes' frustum
  DepthCropConfig crop;
  double sync_slop = 0.02;  ///< [s] max colour/depth stamp difference
  /// The driver's IR amplitude image on the depth image's grid, relative to the node's
  /// namespace as the other topics ("<cam>/" prefixed); "" : none. Matched to the depth by
  /// capture stamp (kinect2_bridge stamps both of one frame alike).
  std::string amplitude_topic = "sd/image_ir_rect";
  int queue_size = 2;       ///< per-topic subscriber queue
  double max_rate = 0.0;    ///< [Hz] of capture time; 0: every frame
  double tf_timeout = 0.05;  ///< [s]
};

const ParamTable<PipeDetectorNodeConfig>& pipeDetectorParamTable();

/// The detector's configuration from the node's parameters: `p.detector` with model "" replaced
/// by `default_model`, the labels from labels_file when set and roi from [x, y, width, height]
/// (checked: four non-negative integers, width and height > 0; InputError naming
/// `roi_source`, e.g. "parameter /cam1/pipe_detector/roi"). Used by the node and detect_bag.
detector::DetectorConfig detectorConfigFromParams(const PipeDetectorNodeConfig& p,
                                                  const std::string& default_model,
                                                  const std::string& roi_source);

/// The pipe_detector parameter table of docs/parameters.md (Markdown).
std::string pipeDetectorParamsMarkdown();

}  // namespace drill_pipe_pose
