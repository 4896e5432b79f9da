#pragma once
// YOLO post-processing without OpenCV or ROS: letterbox geometry, decoding of the common YOLO
// output layouts, greedy NMS and per-class top-k. Pure maths on float arrays, so it is tested on
// synthetic network outputs in milliseconds.
//
// Coordinates: pixels, x right, y down. Three frames of pixels appear here:
//  - image: the full colour image of the SensorFrame (what PipeBox coordinates refer to),
//  - roi:   the region of interest cut out of the image (offset roi_x, roi_y in the image),
//  - input: the network input (input_width x input_height), the roi scaled by `scale` and
//           centred with padding (letterbox).

#include <cstdint>
#include <string>
#include <vector>

namespace drill_pipe_pose::detector {

/// An axis-aligned box [px] with a class and a score.
struct ScoredBox {
  int class_id = 0;
  float score = 0.0f;  ///< [0, 1] objectness x class probability
  float x_min = 0, y_min = 0, x_max = 0, y_max = 0;
  float width() const { return x_max - x_min; }
  float height() const { return y_max - y_min; }
};

/// Intersection over union of two boxes (0 when either is empty).
float iou(const ScoredBox& a, const ScoredBox& b);

/// Letterbox mapping between a region of the colour image and the network input: the roi is
/// scaled uniformly by `scale` (aspect ratio kept) and padded symmetrically to the input size.
struct Letterbox {
  int roi_x = 0, roi_y = 0;                   ///< [px] top-left of the roi in the full image
  int roi_width = 0, roi_height = 0;          ///< [px]
  int input_width = 0, input_height = 0;      ///< [px] network input
  double scale = 1.0;                         ///< input px per image px
  int resized_width = 0, resized_height = 0;  ///< [px] roi after scaling (<= input size)
  int pad_x = 0, pad_y = 0;                   ///< [px] left / top padding in the input

  /// Letterbox of roi (x, y, w, h) [image px] into an input of input_w x input_h [px]. With
  /// `allow_upscale` false a roi smaller than the input is not enlarged (scale <= 1). Throws
  /// InputError for non-positive sizes.
  static Letterbox compute(int roi_x, int roi_y, int roi_w, int roi_h, int input_w, int input_h,
                           bool allow_upscale = true);

  /// Input pixel position -> full-image pixel position (continuous coordinates, pixel edges).
  float toImageX(float x_input) const {
    return static_cast<float>((x_input - pad_x) / scale + roi_x);
  }
  float toImageY(float y_input) const {
    return static_cast<float>((y_input - pad_y) / scale + roi_y);
  }
  float toInputX(float x_image) const {
    return static_cast<float>((x_image - roi_x) * scale + pad_x);
  }
  float toInputY(float y_image) const {
    return static_cast<float>((y_image - roi_y) * scale + pad_y);
  }
  /// A box in input pixels -> the full image, clipped to the roi.
  ScoredBox toImage(const ScoredBox& b) const;
};

/// The output layouts the decoder understands.
enum class OutputFormat {
  kAuto,     ///< guessed from the output shapes (see guessOutputFormat)
  kGrid,     ///< this repository's anchor-free head: [1, 5 + C, H, W] per output, one per stride
             ///< (stride = input / H). Channels: sigmoid(tx), sigmoid(ty), tw, th, sigmoid(obj),
             ///< sigmoid(class)... ; centre = (col + 2 sx - 0.5) stride, size = stride exp(tw)
  kYoloV5,   ///< decoded [1, N, 5 + C]: cx, cy, w, h [input px], objectness, class probs
  kYoloV8,   ///< decoded [1, 4 + C, N]: cx, cy, w, h [input px], class probs (no objectness)
  kDarknet,  ///< OpenCV's Darknet [yolo]/[region] output [N, 5 + C]: cx, cy, w, h normalised to
             ///< the input size, objectness, class scores (already multiplied by objectness)
};

/// "auto" | "grid" | "yolov5" | "yolov8" | "darknet"; throws InputError naming `source`.
OutputFormat parseOutputFormat(const std::string& name, const std::string& source);
const char* outputFormatName(OutputFormat f);

/// One network output blob: row-major, dims as OpenCV reports them (e.g. {1, 7, 52, 52}).
struct OutputBlob {
  std::vector<int> dims;
  const float* data = nullptr;
  size_t size() const;  ///< number of floats
};

/// The format and class count a set of outputs implies, for `input` of input_w x input_h.
/// kAuto input: 4-D outputs -> kGrid; 3-D [1, N, K] with N > K -> kYoloV5; [1, K, N] with
/// K < N -> kYoloV8; 2-D -> kDarknet. Throws InputError naming `source` when the shapes fit no
/// format (a dimension < 1 fits none) or disagree between outputs.
struct OutputLayout {
  OutputFormat format = OutputFormat::kGrid;
  int num_classes = 0;
};
OutputLayout guessOutputLayout(const std::vector<OutputBlob>& outputs, OutputFormat format,
                               const std::string& source);

/// Decodes every candidate whose score (objectness x class probability, for each class) is at
/// least `score_threshold` into boxes in INPUT pixels. One candidate can yield several classes.
/// Throws InputError when an output's shape does not fit `layout` (its format with
/// layout.num_classes classes, every dimension >= 1) or it has no data.
std::vector<ScoredBox> decodeOutputs(const std::vector<OutputBlob>& outputs,
                                     const OutputLayout& layout, int input_width, int input_height,
                                     float score_threshold);

/// Greedy non-maximum suppression per class: keeps the highest-scoring box and drops boxes of the
/// same class overlapping it with IoU > iou_threshold. With `class_agnostic`, boxes of any class
/// suppress each other. Output sorted by descending score.
std::vector<ScoredBox> nonMaximumSuppression(std::vector<ScoredBox> boxes, float iou_threshold,
                                             bool class_agnostic = false);

/// At most `k` boxes per class (the highest scores), k <= 0: no limit. Sorted by score.
std::vector<ScoredBox> topKPerClass(std::vector<ScoredBox> boxes, int k);

/// The detector's post-processing of decoded boxes (YoloDetector::detectRaw; YoloConfig holds
/// the same fields): each box to the full image through `letterbox` (clipped to the roi), boxes
/// left empty dropped, at most max_candidates (the highest scores), NMS per class, then across
/// classes when cross_class_nms_threshold < 1, at most max_boxes_per_class per class (<= 0: no
/// limit). Sorted by descending score.
struct PostprocessConfig {
  int max_candidates = 1000;
  float nms_threshold = 0.45f;
  float cross_class_nms_threshold = 0.7f;
  int max_boxes_per_class = 1;
};
std::vector<ScoredBox> postprocessBoxes(std::vector<ScoredBox> boxes, const Letterbox& letterbox,
                                        const PostprocessConfig& config);

}  // namespace drill_pipe_pose::detector
