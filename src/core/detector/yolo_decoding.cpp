#include "drill_pipe_pose/core/detector/yolo_decoding.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose::detector {

float iou(const ScoredBox& a, const ScoredBox& b) {
  const float iw = std::min(a.x_max, b.x_max) - std::max(a.x_min, b.x_min);
  const float ih = std::min(a.y_max, b.y_max) - std::max(a.y_min, b.y_min);
  if (iw <= 0 || ih <= 0) return 0.0f;
  const float inter = iw * ih;
  const float uni = a.width() * a.height() + b.width() * b.height() - inter;
  return uni > 0 ? inter / uni : 0.0f;
}

Letterbox Letterbox::compute(int roi_x, int roi_y, int roi_w, int roi_h, int input_w, int input_h,
                             bool allow_upscale) {
  if (roi_w <= 0 || roi_h <= 0)
    fail("letterbox: region of interest ", roi_w, " x ", roi_h, " px must not be empty");
  if (input_w <= 0 || input_h <= 0)
    fail("letterbox: network input ", input_w, " x ", input_h, " px must not be empty");
  Letterbox l;
  l.roi_x = roi_x;
  l.roi_y = roi_y;
  l.roi_width = roi_w;
  l.roi_height = roi_h;
  l.input_width = input_w;
  l.input_height = input_h;
  l.scale = std::min(static_cast<double>(input_w) / roi_w, static_cast<double>(input_h) / roi_h);
  if (!allow_upscale) l.scale = std::min(l.scale, 1.0);
  l.resized_width = std::clamp(static_cast<int>(std::lround(roi_w * l.scale)), 1, input_w);
  l.resized_height = std::clamp(static_cast<int>(std::lround(roi_h * l.scale)), 1, input_h);
  l.pad_x = (input_w - l.resized_width) / 2;
  l.pad_y = (input_h - l.resized_height) / 2;
  return l;
}

ScoredBox Letterbox::toImage(const ScoredBox& b) const {
  ScoredBox o = b;
  const float x0 = static_cast<float>(roi_x), y0 = static_cast<float>(roi_y);
  // (In double: roi_x + roi_width may not fit in an int for a roi far out.)
  const float x1 = static_cast<float>(static_cast<double>(roi_x) + roi_width),
              y1 = static_cast<float>(static_cast<double>(roi_y) + roi_height);
  o.x_min = std::clamp(toImageX(b.x_min), x0, x1);
  o.x_max = std::clamp(toImageX(b.x_max), x0, x1);
  o.y_min = std::clamp(toImageY(b.y_min), y0, y1);
  o.y_max = std::clamp(toImageY(b.y_max), y0, y1);
  return o;
}

OutputFormat parseOutputFormat(const std::string& name, const std::string& source) {
  if (name == "auto") return OutputFormat::kAuto;
  if (name == "grid") return OutputFormat::kGrid;
  if (name == "yolov5") return OutputFormat::kYoloV5;
  if (name == "yolov8") return OutputFormat::kYoloV8;
  if (name == "darknet") return OutputFormat::kDarknet;
  fail(source, " = '", name, "': expected auto, grid, yolov5, yolov8 or darknet");
}

const char* outputFormatName(OutputFormat f) {
  switch (f) {
    case OutputFormat::kAuto:
      return "auto";
    case OutputFormat::kGrid:
      return "grid";
    case OutputFormat::kYoloV5:
      return "yolov5";
    case OutputFormat::kYoloV8:
      return "yolov8";
    case OutputFormat::kDarknet:
      return "darknet";
  }
  return "?";
}

size_t OutputBlob::size() const {
  if (dims.empty()) return 0;
  size_t n = 1;
  for (int d : dims) n *= static_cast<size_t>(std::max(d, 0));
  return n;
}

namespace {

std::string shapeText(const std::vector<int>& dims) {
  std::ostringstream s;
  s << "[";
  for (size_t i = 0; i < dims.size(); ++i) s << (i ? ", " : "") << dims[i];
  s << "]";
  return s.str();
}

/// Dims without leading 1s beyond `keep` dimensions (OpenCV sometimes drops or adds batch dims).
std::vector<int> squeezeLeading(std::vector<int> dims, size_t keep) {
  while (dims.size() > keep && dims.front() == 1) dims.erase(dims.begin());
  return dims;
}

/// A shape with a dimension < 1 holds nothing to decode (and would make the decoders index past
/// the data it has): fits no layout.
void checkDims(const OutputBlob& b, const std::string& source) {
  for (int d : b.dims)
    if (d < 1)
      fail(source, ": network output of shape ", shapeText(b.dims),
           " has an empty or negative dimension");
}

OutputFormat guessOne(const OutputBlob& b, const std::string& source) {
  checkDims(b, source);
  const std::vector<int> d = b.dims;
  if (d.size() == 4) return OutputFormat::kGrid;
  if (d.size() == 3) return d[1] > d[2] ? OutputFormat::kYoloV5 : OutputFormat::kYoloV8;
  if (d.size() == 2) return OutputFormat::kDarknet;
  fail(source, ": network output of shape ", shapeText(d),
       " fits no YOLO layout (grid [1, 5+C, H, W], yolov5 [1, N, 5+C], yolov8 [1, 4+C, N], "
       "darknet [N, 5+C])");
}

int classesOf(const OutputBlob& b, OutputFormat f, const std::string& source) {
  checkDims(b, source);
  const std::vector<int>& d = b.dims;
  int c = -1;
  switch (f) {
    case OutputFormat::kGrid:
      if (d.size() == 4) c = d[1] - 5;
      break;
    case OutputFormat::kYoloV5:
      if (d.size() == 3 || d.size() == 2) c = d.back() - 5;
      break;
    case OutputFormat::kYoloV8:
      if (d.size() == 3)
        c = d[1] - 4;
      else if (d.size() == 2)
        c = d[0] - 4;
      break;
    case OutputFormat::kDarknet: {
      const std::vector<int> s = squeezeLeading(d, 2);
      if (s.size() == 2) c = s[1] - 5;
      break;
    }
    case OutputFormat::kAuto:
      break;
  }
  if (c < 1)
    fail(source, ": network output of shape ", shapeText(d), " does not fit the ",
         outputFormatName(f), " layout (no class channels)");
  return c;
}

void pushClasses(std::vector<ScoredBox>* out, float cx, float cy, float w, float h, float obj,
                 const float* cls, int cls_stride, int num_classes, float threshold) {
  if (obj < threshold) return;
  for (int c = 0; c < num_classes; ++c) {
    const float s = obj * cls[static_cast<size_t>(c) * cls_stride];
    if (s < threshold) continue;
    ScoredBox b;
    b.class_id = c;
    b.score = s;
    b.x_min = cx - 0.5f * w;
    b.x_max = cx + 0.5f * w;
    b.y_min = cy - 0.5f * h;
    b.y_max = cy + 0.5f * h;
    out->push_back(b);
  }
}

}  // namespace

OutputLayout guessOutputLayout(const std::vector<OutputBlob>& outputs, OutputFormat format,
                               const std::string& source) {
  if (outputs.empty()) fail(source, ": the network has no outputs");
  OutputLayout l;
  l.format = format == OutputFormat::kAuto ? guessOne(outputs.front(), source) : format;
  l.num_classes = classesOf(outputs.front(), l.format, source);
  for (size_t i = 1; i < outputs.size(); ++i) {
    const int c = classesOf(outputs[i], l.format, source);
    if (c != l.num_classes)
      fail(source, ": output ", i, " of shape ", shapeText(outputs[i].dims), " implies ", c,
           " classes, output 0 implies ", l.num_classes);
  }
  return l;
}

std::vector<ScoredBox> decodeOutputs(const std::vector<OutputBlob>& outputs,
                                     const OutputLayout& layout, int input_width, int input_height,
                                     float score_threshold) {
  std::vector<ScoredBox> out;
  const int C = layout.num_classes;
  for (const OutputBlob& b : outputs) {
    // Every index read below lies inside the blob only for a shape of the layout with C classes
    // and data behind it: checked on every call, the outputs being another forward pass's.
    if (layout.format != OutputFormat::kAuto && classesOf(b, layout.format, "decodeOutputs") != C)
      fail("decodeOutputs: network output of shape ", shapeText(b.dims), " does not have the ",
           C, " classes of the ", outputFormatName(layout.format), " layout");
    if (!b.data) fail("decodeOutputs: network output of shape ", shapeText(b.dims), " has no data");
    const float* p = b.data;
    const std::vector<int>& d = b.dims;
    switch (layout.format) {
      case OutputFormat::kGrid: {
        const int H = d[2], W = d[3];
        const size_t plane = static_cast<size_t>(H) * W;
        const float sx = static_cast<float>(input_width) / W;
        const float sy = static_cast<float>(input_height) / H;
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) {
            const size_t i = static_cast<size_t>(y) * W + x;
            const float obj = p[4 * plane + i];
            if (obj < score_threshold) continue;
            const float cx = (x + 2.0f * p[i] - 0.5f) * sx;
            const float cy = (y + 2.0f * p[plane + i] - 0.5f) * sy;
            const float w = sx * std::exp(std::min(p[2 * plane + i], 8.0f));
            const float h = sy * std::exp(std::min(p[3 * plane + i], 8.0f));
            pushClasses(&out, cx, cy, w, h, obj, p + 5 * plane + i, static_cast<int>(plane), C,
                        score_threshold);
          }
        break;
      }
      case OutputFormat::kYoloV5: {
        const int N = d.size() == 3 ? d[1] : d[0];
        const int K = d.back();
        for (int n = 0; n < N; ++n) {
          const float* r = p + static_cast<size_t>(n) * K;
          pushClasses(&out, r[0], r[1], r[2], r[3], r[4], r + 5, 1, C, score_threshold);
        }
        break;
      }
      case OutputFormat::kYoloV8: {
        const int N = d.back();
        for (int n = 0; n < N; ++n) {
          const float* r = p + n;
          pushClasses(&out, r[0], r[static_cast<size_t>(N)], r[2 * static_cast<size_t>(N)],
                      r[3 * static_cast<size_t>(N)], 1.0f, r + 4 * static_cast<size_t>(N), N, C,
                      score_threshold);
        }
        break;
      }
      case OutputFormat::kDarknet: {
        const std::vector<int> s = squeezeLeading(d, 2);
        const int N = s[0], K = s[1];
        for (int n = 0; n < N; ++n) {
          const float* r = p + static_cast<size_t>(n) * K;
          // Class scores already include the objectness: score = class score.
          for (int c = 0; c < C; ++c) {
            const float sc = r[5 + c];
            if (sc < score_threshold || sc <= 0.0f) continue;
            ScoredBox bx;
            bx.class_id = c;
            bx.score = sc;
            const float cx = r[0] * input_width, cy = r[1] * input_height;
            const float w = r[2] * input_width, h = r[3] * input_height;
            bx.x_min = cx - 0.5f * w;
            bx.x_max = cx + 0.5f * w;
            bx.y_min = cy - 0.5f * h;
            bx.y_max = cy + 0.5f * h;
            out.push_back(bx);
          }
        }
        break;
      }
      case OutputFormat::kAuto:
        fail("decodeOutputs: the layout must be resolved (not auto)");
    }
  }
  return out;
}

std::vector<ScoredBox> nonMaximumSuppression(std::vector<ScoredBox> boxes, float iou_threshold,
                                             bool class_agnostic) {
  std::stable_sort(boxes.begin(), boxes.end(),
                   [](const ScoredBox& a, const ScoredBox& b) { return a.score > b.score; });
  std::vector<ScoredBox> kept;
  std::vector<bool> removed(boxes.size(), false);
  for (size_t i = 0; i < boxes.size(); ++i) {
    if (removed[i]) continue;
    kept.push_back(boxes[i]);
    for (size_t j = i + 1; j < boxes.size(); ++j) {
      if (removed[j]) continue;
      if (!class_agnostic && boxes[j].class_id != boxes[i].class_id) continue;
      if (iou(boxes[i], boxes[j]) > iou_threshold) removed[j] = true;
    }
  }
  return kept;
}

std::vector<ScoredBox> topKPerClass(std::vector<ScoredBox> boxes, int k) {
  std::stable_sort(boxes.begin(), boxes.end(),
                   [](const ScoredBox& a, const ScoredBox& b) { return a.score > b.score; });
  if (k <= 0) return boxes;
  std::vector<ScoredBox> out;
  std::vector<int> count;
  for (const ScoredBox& b : boxes) {
    if (b.class_id < 0) continue;
    if (static_cast<size_t>(b.class_id) >= count.size()) count.resize(b.class_id + 1, 0);
    if (count[b.class_id]++ < k) out.push_back(b);
  }
  return out;
}

std::vector<ScoredBox> postprocessBoxes(std::vector<ScoredBox> boxes, const Letterbox& letterbox,
                                        const PostprocessConfig& config) {
  for (ScoredBox& b : boxes) b = letterbox.toImage(b);
  boxes.erase(std::remove_if(boxes.begin(), boxes.end(),
                             [](const ScoredBox& b) { return b.width() <= 0 || b.height() <= 0; }),
              boxes.end());
  if (boxes.size() > static_cast<size_t>(config.max_candidates)) {
    std::nth_element(boxes.begin(), boxes.begin() + config.max_candidates, boxes.end(),
                     [](const ScoredBox& a, const ScoredBox& b) { return a.score > b.score; });
    boxes.resize(static_cast<size_t>(config.max_candidates));
  }
  boxes = nonMaximumSuppression(std::move(boxes), config.nms_threshold, false);
  if (config.cross_class_nms_threshold < 1.0f)
    boxes = nonMaximumSuppression(std::move(boxes), config.cross_class_nms_threshold, true);
  return topKPerClass(std::move(boxes), config.max_boxes_per_class);
}

}  // namespace drill_pipe_pose::detector
