// Fuzz harness: YOLO output decoding (core/detector/yolo_decoding.hpp) on random tensors and
// shapes.
//
// The pipe_detector node decodes whatever a model file's network outputs: a model exported with
// another head, another class count or batch size, an OpenCV version that adds or drops a batch
// dimension, NaN or inf activations of a broken model. This harness builds 1-3 output blobs from
// the fuzz bytes (any rank 0-5, any dims including 0 and negative ones, data of exactly the
// shape's size, as OpenCV hands it over) and runs what YoloDetector does with them:
// guessOutputLayout (auto or a forced format; InputError documented for shapes that fit no
// layout), decodeOutputs, and the post-processing (postprocessBoxes: letterbox back to the image,
// candidate cap, per-class and cross-class NMS, top-k) with fuzzed thresholds and letterbox.
// Checked beyond "no crash": what the post-processing documents about its output (at most
// max_boxes_per_class boxes per class, class ids of the layout's classes).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <map>
#include <vector>

#include "drill_pipe_pose/core/detector/yolo_decoding.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "fuzz_input.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::detector;

namespace {

/// Most floats a fuzzed output may hold (a 960x544 grid head has ~50k per class channel).
constexpr size_t kMaxFloats = size_t{1} << 18;

/// A dimension: mostly small (including 0 and negative), sometimes raw.
int readDim(fuzz::FuzzReader& r) {
  const uint8_t s = r.u8();
  if (s < 0xF0) return static_cast<int>(s % 24) - 2;  // -2 .. 21
  return static_cast<int>(r.u32());
}

/// An int such as an input size: small, typical, zero, negative or raw.
int readSize(fuzz::FuzzReader& r) {
  switch (r.u8() % 6) {
    case 0: return 416;
    case 1: return 960;
    case 2: return 0;
    case 3: return -static_cast<int>(r.u8());
    case 4: return static_cast<int>(r.u16());
    default: return static_cast<int>(r.u32());
  }
}

[[noreturn]] void violated(const char* what) {
  std::fprintf(stderr, "fuzz_yolo_decoding: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::FuzzReader r(data, size);
  const int n_outputs = 1 + r.u8() % 3;
  const auto format = static_cast<OutputFormat>(r.u8() % 5);
  std::vector<std::vector<float>> storage(n_outputs);
  std::vector<OutputBlob> outs(n_outputs);
  for (int o = 0; o < n_outputs; ++o) {
    const int rank = r.u8() % 6;
    for (int k = 0; k < rank; ++k) outs[o].dims.push_back(readDim(r));
    // Data of exactly the shape's size, as OpenCV's Mat gives it; a shape too big for that is
    // not something OpenCV could hand over: not an input of this harness.
    size_t n = outs[o].dims.empty() ? 0 : 1;
    for (int d : outs[o].dims) {
      n *= static_cast<size_t>(std::max(d, 0));
      if (n > kMaxFloats) return 0;
    }
    std::vector<float>& v = storage[o];
    v.resize(n);
    switch (r.u8() % 3) {
      case 0:  // each value coded: special values (NaN, inf, ...) where the selector says so
        for (float& x : v) x = r.f32();
        break;
      case 1: {  // a constant
        const float c = r.f32();
        for (float& x : v) x = c;
        break;
      }
      default:  // raw bytes, zeros past the input's end
        r.read(v.data(), v.size() * sizeof(float));
        break;
    }
    outs[o].data = v.data();
  }
  const int input_w = readSize(r), input_h = readSize(r);
  const float threshold = r.f32();

  OutputLayout layout;
  try {
    layout = guessOutputLayout(outs, format, "fuzz");
  } catch (const InputError&) {
    return 0;
  }
  std::vector<ScoredBox> boxes = decodeOutputs(outs, layout, input_w, input_h, threshold);

  Letterbox lb;
  try {
    lb = Letterbox::compute(readSize(r), readSize(r), readSize(r), readSize(r), input_w, input_h,
                            r.u8() & 1);
  } catch (const InputError&) {
    return 0;
  }
  PostprocessConfig post;
  post.max_candidates = readSize(r);
  post.nms_threshold = r.f32();
  post.cross_class_nms_threshold = r.f32();
  post.max_boxes_per_class = static_cast<int>(r.u8() % 4);
  const std::vector<ScoredBox> out = postprocessBoxes(std::move(boxes), lb, post);

  std::map<int, int> per_class;
  for (const ScoredBox& b : out) {
    if (post.max_boxes_per_class > 0 && ++per_class[b.class_id] > post.max_boxes_per_class)
      violated("more boxes of a class than max_boxes_per_class");
    if (b.class_id < 0 || b.class_id >= layout.num_classes) violated("class id out of range");
  }
  return 0;
}
