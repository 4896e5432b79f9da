#pragma once
// The detector's training data on disk: a YOLO dataset and a Pascal VOC dataset of colour images
// with their boxes, in the layout scripts/train_detector.py and scripts/voc_yolo.py read. One
// writer for every tool that makes such data (render_dataset, label_from_poses).
//
// Layout: OUT/yolo/{images,labels}/<split>/<name>.{jpg,txt} (class cx cy w h, normalised),
// OUT/yolo/classes.txt, OUT/yolo/<split>.txt (image list); OUT/voc/JPEGImages/<name>.jpg,
// OUT/voc/Annotations/<name>.xml, OUT/voc/ImageSets/Main/<split>.txt.

#include <opencv2/core.hpp>

#include <array>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"

namespace drill_pipe_pose {

struct DatasetWriterOptions {
  std::string out;               ///< dataset root
  std::string split = "train";   ///< split the images go to
  std::string format = "both";   ///< both | yolo | voc
  int jpeg_quality = 92;
  std::string source = "drill_pipe_pose rig_simulator";  ///< VOC <source><database>
  std::string tool = "render_dataset";                   ///< names the writer in errors
};

class DatasetWriter {
 public:
  /// Creates the folders (appends to the split's lists). Throws InputError naming the folder when
  /// it cannot be created.
  explicit DatasetWriter(const DatasetWriterOptions& options);
  /// Writes one image with its boxes [full-image px]. Throws InputError naming the file.
  void write(const std::string& name, const cv::Mat& bgr, const std::vector<DetectionBox>& boxes);
  size_t images() const { return images_; }
  size_t boxes(EndLabel e) const { return boxes_[static_cast<int>(e)]; }
  const DatasetWriterOptions& options() const { return o_; }

 private:
  DatasetWriterOptions o_;
  std::filesystem::path yolo_, voc_;
  std::ofstream yolo_list_, voc_list_;
  size_t images_ = 0;
  std::array<size_t, kNumEnds> boxes_{{0, 0}};
};

}  // namespace drill_pipe_pose
