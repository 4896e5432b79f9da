// Sensor-node detector (core/detector): letterbox maths, decoding of every supported YOLO output
// layout on synthetic outputs, NMS and top-k, the Darknet path with a tiny network written here,
// bad input, and the shipped ONNX model on rendered images of the thesis rig.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "drill_pipe_pose/core/detector/yolo_decoding.hpp"
#include "drill_pipe_pose/core/detector/yolo_detector.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::detector;
namespace fs = std::filesystem;

namespace {

const std::string kSource = DRILL_PIPE_POSE_SOURCE_DIR;
const std::string kModel = kSource + "/models/detector/pipe_yolo.onnx";

/// Expects `f` to throw InputError whose message contains every one of `parts`.
template <typename F>
void expectError(F&& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    for (const auto& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos)
          << "message '" << e.what() << "' lacks '" << p << "'";
  }
}

ScoredBox box(int cls, float score, float x0, float y0, float x1, float y1) {
  ScoredBox b;
  b.class_id = cls;
  b.score = score;
  b.x_min = x0;
  b.y_min = y0;
  b.x_max = x1;
  b.y_max = y1;
  return b;
}

fs::path tempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() /
                     ("drill_pipe_pose_test_detector_" + name + "_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
TEST(Letterbox, WholeQhdImageIntoSquareInput) {
  const Letterbox l = Letterbox::compute(0, 0, 960, 540, 416, 416);
  EXPECT_NEAR(l.scale, 416.0 / 960.0, 1e-12);
  EXPECT_EQ(l.resized_width, 416);
  EXPECT_EQ(l.resized_height, 234);
  EXPECT_EQ(l.pad_x, 0);
  EXPECT_EQ(l.pad_y, 91);
  // Image corners map to the resized area's corners, and back.
  EXPECT_NEAR(l.toInputX(0), 0, 1e-4);
  EXPECT_NEAR(l.toInputY(0), 91, 1e-4);
  EXPECT_NEAR(l.toInputX(960), 416, 1e-3);
  EXPECT_NEAR(l.toInputY(540), 91 + 234, 0.1);
  for (float x : {0.0f, 123.4f, 959.0f}) EXPECT_NEAR(l.toImageX(l.toInputX(x)), x, 1e-3);
  for (float y : {0.0f, 77.7f, 539.0f}) EXPECT_NEAR(l.toImageY(l.toInputY(y)), y, 1e-3);
}

TEST(Letterbox, RoiOffsetsAndNoUpscale) {
  // A 300 x 200 roi at (100, 50) into 416 x 416 without upscaling: scale 1, centred.
  const Letterbox l = Letterbox::compute(100, 50, 300, 200, 416, 416, false);
  EXPECT_DOUBLE_EQ(l.scale, 1.0);
  EXPECT_EQ(l.pad_x, 58);
  EXPECT_EQ(l.pad_y, 108);
  EXPECT_FLOAT_EQ(l.toImageX(58), 100);
  EXPECT_FLOAT_EQ(l.toImageY(108), 50);
  // With upscaling: 416 / 300.
  const Letterbox u = Letterbox::compute(100, 50, 300, 200, 416, 416, true);
  EXPECT_NEAR(u.scale, 416.0 / 300.0, 1e-12);
  EXPECT_EQ(u.pad_x, 0);
  // A box in input pixels maps into the image and is clipped to the roi.
  const ScoredBox b = l.toImage(box(1, 0.9f, 40, 100, 78, 130));
  EXPECT_FLOAT_EQ(b.x_min, 100);  // clipped at the roi's left edge
  EXPECT_FLOAT_EQ(b.x_max, 120);
  EXPECT_FLOAT_EQ(b.y_min, 50);
  EXPECT_FLOAT_EQ(b.y_max, 72);
  EXPECT_EQ(b.class_id, 1);
  expectError([] { Letterbox::compute(0, 0, 0, 10, 416, 416); }, {"region of interest"});
}

TEST(Iou, Basics) {
  EXPECT_FLOAT_EQ(iou(box(0, 1, 0, 0, 10, 10), box(0, 1, 0, 0, 10, 10)), 1.0f);
  EXPECT_FLOAT_EQ(iou(box(0, 1, 0, 0, 10, 10), box(0, 1, 5, 0, 15, 10)), 50.0f / 150.0f);
  EXPECT_FLOAT_EQ(iou(box(0, 1, 0, 0, 10, 10), box(0, 1, 20, 20, 30, 30)), 0.0f);
}

// ---------------------------------------------------------------------------------------------
TEST(Decode, GridLayout) {
  // [1, 7, 4, 5]: 2 classes, 4 rows x 5 columns, input 40 x 32 -> stride 8.
  const int C = 7, H = 4, W = 5;
  std::vector<float> out(static_cast<size_t>(C) * H * W, 0.0f);
  auto at = [&](int c, int y, int x) -> float& {
    return out[(static_cast<size_t>(c) * H + y) * W + x];
  };
  // Cell (row 2, col 3): sx = 0.75 -> centre x = (3 + 1.5 - 0.5) * 8 = 32; sy = 0.25 -> y = 16.
  at(0, 2, 3) = 0.75f;
  at(1, 2, 3) = 0.25f;
  at(2, 2, 3) = std::log(2.0f);  // width 16
  at(3, 2, 3) = std::log(3.0f);  // height 24
  at(4, 2, 3) = 0.9f;            // objectness
  at(5, 2, 3) = 0.2f;            // box_end
  at(6, 2, 3) = 0.8f;            // pin_end
  at(4, 0, 0) = 0.1f;            // below threshold
  at(6, 0, 0) = 1.0f;
  OutputBlob b;
  b.dims = {1, C, H, W};
  b.data = out.data();
  const OutputLayout l = guessOutputLayout({b}, OutputFormat::kAuto, "test");
  EXPECT_EQ(l.format, OutputFormat::kGrid);
  EXPECT_EQ(l.num_classes, 2);
  const auto boxes = decodeOutputs({b}, l, 40, 32, 0.3f);
  ASSERT_EQ(boxes.size(), 1u);  // pin_end 0.72; box_end 0.18 is below 0.3
  EXPECT_EQ(boxes[0].class_id, 1);
  EXPECT_NEAR(boxes[0].score, 0.72f, 1e-6);
  EXPECT_NEAR(boxes[0].x_min, 24.0f, 1e-4);
  EXPECT_NEAR(boxes[0].x_max, 40.0f, 1e-4);
  EXPECT_NEAR(boxes[0].y_min, 4.0f, 1e-4);
  EXPECT_NEAR(boxes[0].y_max, 28.0f, 1e-4);
  EXPECT_EQ(decodeOutputs({b}, l, 40, 32, 0.15f).size(), 2u);  // both classes at 0.15
}

TEST(Decode, YoloV5AndV8Layouts) {
  // v5: [1, 3, 7] rows cx, cy, w, h, obj, p0, p1 (N = 3 > 7? no: N < K, so give the format).
  std::vector<float> v5 = {100, 50, 20, 10, 0.9f, 0.9f, 0.1f,  //
                           10,  10, 4,  4,  0.1f, 0.9f, 0.9f,  //
                           200, 80, 10, 30, 0.8f, 0.2f, 0.9f};
  OutputBlob b5;
  b5.dims = {1, 3, 7};
  b5.data = v5.data();
  const OutputLayout l5 = guessOutputLayout({b5}, OutputFormat::kYoloV5, "v5");
  EXPECT_EQ(l5.num_classes, 2);
  auto d5 = decodeOutputs({b5}, l5, 416, 416, 0.5f);
  ASSERT_EQ(d5.size(), 2u);
  EXPECT_EQ(d5[0].class_id, 0);
  EXPECT_NEAR(d5[0].score, 0.81f, 1e-6);
  EXPECT_FLOAT_EQ(d5[0].x_min, 90);
  EXPECT_FLOAT_EQ(d5[0].y_max, 55);
  EXPECT_EQ(d5[1].class_id, 1);
  EXPECT_NEAR(d5[1].score, 0.72f, 1e-6);
  // Auto: [1, 8400, 7] -> v5; [1, 6, 8400] -> v8.
  OutputBlob big;
  big.dims = {1, 8400, 7};
  EXPECT_EQ(guessOutputLayout({big}, OutputFormat::kAuto, "x").format, OutputFormat::kYoloV5);
  big.dims = {1, 6, 8400};
  const OutputLayout l8 = guessOutputLayout({big}, OutputFormat::kAuto, "x");
  EXPECT_EQ(l8.format, OutputFormat::kYoloV8);
  EXPECT_EQ(l8.num_classes, 2);
  // v8: [1, 6, 2] (columns are candidates): cx, cy, w, h, p0, p1.
  std::vector<float> v8 = {100,  300,   //
                           50,   60,    //
                           20,   8,     //
                           10,   8,     //
                           0.3f, 0.1f,  //
                           0.6f, 0.95f};
  OutputBlob b8;
  b8.dims = {1, 6, 2};
  b8.data = v8.data();
  auto d8 = decodeOutputs({b8}, l8, 416, 416, 0.5f);
  ASSERT_EQ(d8.size(), 2u);
  EXPECT_EQ(d8[0].class_id, 1);
  EXPECT_FLOAT_EQ(d8[0].score, 0.6f);
  EXPECT_FLOAT_EQ(d8[0].x_min, 90);
  EXPECT_EQ(d8[1].class_id, 1);
  EXPECT_FLOAT_EQ(d8[1].x_min, 296);
}

TEST(Decode, DarknetLayoutAndMultipleOutputs) {
  // Two [N, 7] outputs (OpenCV's [yolo] layers): normalised boxes, class scores x objectness.
  std::vector<float> a = {0.5f, 0.5f, 0.1f, 0.2f, 0.9f, 0.0f, 0.85f};
  std::vector<float> b = {0.25f, 0.75f, 0.05f, 0.05f, 0.7f, 0.6f, 0.0f,  //
                          0.1f,  0.1f,  0.05f, 0.05f, 0.1f, 0.0f, 0.0f};
  OutputBlob oa, ob;
  oa.dims = {1, 7};
  oa.data = a.data();
  ob.dims = {2, 7};
  ob.data = b.data();
  const OutputLayout l = guessOutputLayout({oa, ob}, OutputFormat::kAuto, "darknet");
  EXPECT_EQ(l.format, OutputFormat::kDarknet);
  EXPECT_EQ(l.num_classes, 2);
  const auto d = decodeOutputs({oa, ob}, l, 320, 160, 0.25f);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].class_id, 1);
  EXPECT_FLOAT_EQ(d[0].score, 0.85f);
  EXPECT_FLOAT_EQ(d[0].x_min, 160 - 16);
  EXPECT_FLOAT_EQ(d[0].y_max, 80 + 16);
  EXPECT_EQ(d[1].class_id, 0);
  EXPECT_FLOAT_EQ(d[1].x_min, 80 - 8);
}

TEST(Decode, BadShapesNameTheSource) {
  OutputBlob b;
  b.dims = {7};
  expectError([&] { guessOutputLayout({b}, OutputFormat::kAuto, "model 'x.onnx'"); },
              {"model 'x.onnx'", "[7]"});
  b.dims = {1, 4, 10, 10};  // grid without class channels
  expectError([&] { guessOutputLayout({b}, OutputFormat::kAuto, "m"); },
              {"grid", "[1, 4, 10, 10]"});
  OutputBlob c;
  c.dims = {1, 8, 5, 5};
  b.dims = {1, 7, 10, 10};
  expectError([&] { guessOutputLayout({b, c}, OutputFormat::kGrid, "m"); }, {"3 classes", "2"});
  expectError([] { parseOutputFormat("yolov9", "parameter ~output_format"); },
              {"~output_format", "yolov9"});
}

// Found by test/fuzz/fuzz_yolo_decoding (test/fuzz/regressions/yolo_decoding/): a shape with a
// zero dimension passed guessOutputLayout and decodeOutputs read past its (empty) data; an output
// of another shape than the layout's was decoded past its end; the letterbox's roi end overflowed
// an int.
TEST(Decode, EmptyOrMismatchedShapesAreRejected) {
  OutputBlob b;
  b.dims = {0, 7, 4, 5};  // no data at all
  expectError([&] { guessOutputLayout({b}, OutputFormat::kAuto, "m"); },
              {"m", "[0, 7, 4, 5]", "empty or negative"});
  b.dims = {1, 7, -4, 5};
  expectError([&] { guessOutputLayout({b}, OutputFormat::kGrid, "m"); }, {"[1, 7, -4, 5]"});
  std::vector<float> data(7 * 4 * 5, 0.0f);
  b.dims = {1, 7, 4, 5};
  b.data = data.data();
  const OutputLayout l = guessOutputLayout({b}, OutputFormat::kAuto, "m");
  OutputBlob other = b;
  other.dims = {1, 9, 4, 5};  // another forward pass's shape: 4 classes, not 2
  expectError([&] { decodeOutputs({other}, l, 40, 32, 0.3f); }, {"[1, 9, 4, 5]", "2 classes"});
  other.dims = {0, 7, 4, 5};
  expectError([&] { decodeOutputs({other}, l, 40, 32, 0.3f); }, {"[0, 7, 4, 5]"});
  other.dims = b.dims;
  other.data = nullptr;
  expectError([&] { decodeOutputs({other}, l, 40, 32, 0.3f); }, {"no data"});
  EXPECT_TRUE(decodeOutputs({b}, l, 40, 32, 0.3f).empty());

  const Letterbox lb = Letterbox::compute(2147483000, 0, 2000, 100, 416, 416);
  const ScoredBox o = lb.toImage(box(0, 0.9f, 0, 0, 416, 416));
  EXPECT_FLOAT_EQ(o.x_max, 2147485000.0f);
}

// ---------------------------------------------------------------------------------------------
TEST(Nms, PerClassCrossClassAndTopK) {
  std::vector<ScoredBox> in = {box(0, 0.9f, 0, 0, 10, 10), box(0, 0.8f, 1, 1, 11, 11),
                               box(0, 0.7f, 50, 50, 60, 60), box(1, 0.85f, 0, 0, 10, 10),
                               box(1, 0.6f, 100, 0, 110, 10)};
  const auto per_class = nonMaximumSuppression(in, 0.45f);
  ASSERT_EQ(per_class.size(), 4u);  // the 0.8 duplicate goes, the other class stays
  EXPECT_FLOAT_EQ(per_class[0].score, 0.9f);
  EXPECT_FLOAT_EQ(per_class[1].score, 0.85f);
  const auto agnostic = nonMaximumSuppression(in, 0.45f, true);
  ASSERT_EQ(agnostic.size(), 3u);  // the pin_end on the same spot goes too
  for (const auto& b : agnostic) EXPECT_NE(b.score, 0.85f);
  const auto top1 = topKPerClass(per_class, 1);
  ASSERT_EQ(top1.size(), 2u);
  EXPECT_EQ(top1[0].class_id, 0);
  EXPECT_FLOAT_EQ(top1[0].score, 0.9f);
  EXPECT_EQ(top1[1].class_id, 1);
  EXPECT_FLOAT_EQ(top1[1].score, 0.85f);
  EXPECT_EQ(topKPerClass(per_class, 0).size(), 4u);
  EXPECT_EQ(topKPerClass(per_class, 2).size(), 4u);
}

// ---------------------------------------------------------------------------------------------
TEST(ColorImage, EncodingsAndErrors) {
  std::vector<uint8_t> rgb = {10, 20, 30, 40, 50, 60};
  const cv::Mat bgr = colorImageToBgr("rgb8", 2, 1, 6, rgb.data(), rgb.size(), "/cam1/qhd/image");
  ASSERT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0)[0], 30);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 1)[2], 40);
  const cv::Mat same = colorImageToBgr("bgr8", 2, 1, 6, rgb.data(), rgb.size(), "t");
  EXPECT_EQ(same.data, rgb.data());  // wrapped, not copied
  expectError([&] { colorImageToBgr("16UC1", 2, 1, 4, rgb.data(), rgb.size(), "/cam1/qhd/image"); },
              {"/cam1/qhd/image", "16UC1", "not supported"});
  expectError([&] { colorImageToBgr("bgr8", 4, 1, 12, rgb.data(), rgb.size(), "/cam1/qhd/image"); },
              {"/cam1/qhd/image", "step"});
  expectError([&] { colorImageToBgr("bgr8", 2, 2, 6, rgb.data(), rgb.size(), "/cam1/qhd/image"); },
              {"/cam1/qhd/image", "bytes"});
}

TEST(SameCamera, FrameIdsMustAgree) {
  EXPECT_NO_THROW(
      checkSameCamera("cam1", "cam1_rgb_optical_frame", "c", "cam1_ir_optical_frame", "d"));
  EXPECT_NO_THROW(
      checkSameCamera("", "/cam2_rgb_optical_frame", "c", "cam2_ir_optical_frame", "d"));
  EXPECT_NO_THROW(
      checkSameCamera("cam1", "color_optical", "c", "depth_optical", "d"));  // other drivers
  expectError(
      [] {
        checkSameCamera("cam1", "cam1_rgb_optical_frame", "/cam1/qhd/image_color_rect",
                        "cam2_ir_optical_frame", "/cam1/sd/image_depth_rect");
      },
      {"different cameras", "/cam1/qhd/image_color_rect", "/cam1/sd/image_depth_rect",
       "cam2_ir_optical_frame"});
  expectError(
      [] {
        checkSameCamera("cam1", "cam3_rgb_optical_frame", "/cam1/qhd/image_color_rect",
                        "cam3_ir_optical_frame", "/cam1/sd/image_depth_rect");
      },
      {"/cam1/qhd/image_color_rect", "cam3", "cam1"});
  expectError([] { checkSameCamera("cam1", "", "/c", "cam1_ir_optical_frame", "/d"); },
              {"/c", "frame_id"});
}

TEST(Roi, MustLieInsideTheImage) {
  ImageRoi r;
  EXPECT_NO_THROW(checkRoi(r, 960, 540, "parameter ~roi"));
  r.x_offset = 500;
  r.y_offset = 100;
  r.width = 460;
  r.height = 440;
  EXPECT_NO_THROW(checkRoi(r, 960, 540, "parameter ~roi"));
  r.width = 461;
  expectError([&] { checkRoi(r, 960, 540, "parameter /cam1_detector/roi"); },
              {"/cam1_detector/roi", "500, 100, 461, 440", "960 x 540"});
  r.width = 0;
  expectError([&] { checkRoi(r, 960, 540, "parameter ~roi"); }, {"~roi", "> 0"});
}

TEST(Labels, FileAndValidation) {
  const fs::path d = tempDir("labels");
  std::ofstream(d / "labels.txt") << "# comment\nbox_end\n\n pin_end \n";
  const auto l = readLabelsFile((d / "labels.txt").string());
  ASSERT_EQ(l.size(), 2u);
  EXPECT_EQ(l[1], "pin_end");
  expectError([&] { readLabelsFile((d / "missing.txt").string()); }, {"missing.txt"});
  fs::remove_all(d);
}

// ---------------------------------------------------------------------------------------------
// Darknet path: a tiny network written here (random weights): it loads, runs, and its [yolo]
// outputs decode.
namespace {

void writeTinyDarknet(const fs::path& dir, int classes) {
  const int filters = 3 * (5 + classes);
  std::ofstream cfg(dir / "tiny.cfg");
  cfg << "[net]\nwidth=64\nheight=64\nchannels=3\n\n"
      << "[convolutional]\nbatch_normalize=1\nfilters=8\nsize=3\nstride=2\npad=1\n"
         "activation=leaky\n\n"
      << "[maxpool]\nsize=2\nstride=2\n\n"
      << "[convolutional]\nsize=1\nstride=1\npad=1\nfilters=" << filters
      << "\nactivation=linear\n\n"
      << "[yolo]\nmask=0,1,2\nanchors=10,14, 23,27, 37,58\nclasses=" << classes
      << "\nnum=3\njitter=.3\nignore_thresh=.7\ntruth_thresh=1\nrandom=1\n";
  std::ofstream w(dir / "tiny.weights", std::ios::binary);
  const int32_t header[3] = {0, 2, 0};
  const int64_t seen = 0;
  w.write(reinterpret_cast<const char*>(header), sizeof(header));
  w.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(-0.5f, 0.5f);
  auto put = [&](int n, float fixed = NAN) {
    for (int i = 0; i < n; ++i) {
      const float v = std::isnan(fixed) ? U(rng) : fixed;
      w.write(reinterpret_cast<const char*>(&v), sizeof(v));
    }
  };
  // conv 1 (batch norm): biases, scales, rolling mean, rolling variance, weights.
  put(8);
  put(8, 1.0f);
  put(8, 0.0f);
  put(8, 1.0f);
  put(8 * 3 * 3 * 3);
  // conv 2 (no batch norm): biases, weights.
  put(filters);
  put(filters * 8);
}

}  // namespace

TEST(Darknet, TinyNetworkLoadsRunsAndDecodes) {
  const fs::path d = tempDir("darknet");
  writeTinyDarknet(d, 2);
  DetectorConfig c;
  c.model = (d / "tiny.weights").string();  // .cfg found next to it
  c.input_width = 64;
  c.input_height = 64;
  c.confidence_threshold = 0.01f;
  c.max_boxes_per_class = 0;
  YoloDetector det(c);
  EXPECT_EQ(det.layout().format, OutputFormat::kDarknet);
  EXPECT_EQ(det.layout().num_classes, 2);
  cv::Mat img(120, 200, CV_8UC3);
  cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(255));
  const auto raw = det.detectRaw(img);
  for (const ScoredBox& b : raw) {  // every box lies in the image and has a class of the model
    EXPECT_GE(b.class_id, 0);
    EXPECT_LT(b.class_id, 2);
    EXPECT_GE(b.x_min, 0.0f);
    EXPECT_LE(b.x_max, 200.0f);
    EXPECT_GE(b.y_min, 0.0f);
    EXPECT_LE(b.y_max, 120.0f);
  }
  const auto boxes = det.detect(img);
  EXPECT_LE(boxes.size(), raw.size());
  // The same network with three configured labels: a class-count mismatch naming the files.
  c.labels = {"box_end", "pin_end", "ignore"};
  expectError([&] { YoloDetector{c}; }, {"tiny.cfg", "tiny.weights", "2 classes", "3 labels"});
  // A missing .cfg is named.
  c.labels = {"box_end", "pin_end"};
  c.darknet_cfg = (d / "nope.cfg").string();
  expectError([&] { YoloDetector{c}; }, {"nope.cfg", "Darknet configuration"});
  fs::remove_all(d);
}

TEST(Detector, BadModelFilesAndConfiguration) {
  const fs::path d = tempDir("bad");
  DetectorConfig c;
  c.model = (d / "missing.onnx").string();
  expectError([&] { YoloDetector{c}; }, {"missing.onnx", "does not exist"});
  std::ofstream(d / "empty.onnx").close();
  c.model = (d / "empty.onnx").string();
  expectError([&] { YoloDetector{c}; }, {"empty.onnx", "empty"});
  std::ofstream(d / "garbage.onnx") << "this is not a protobuf";
  c.model = (d / "garbage.onnx").string();
  expectError([&] { YoloDetector{c}; }, {"garbage.onnx", "ONNX"});
  c.model = (d / "model.pb").string();
  expectError([&] { YoloDetector{c}; }, {"model.pb", "unknown model format"});
  c.model = kModel;
  c.input_width = 400;
  expectError([&] { YoloDetector{c}; }, {"input_width", "400", "32"});
  c.input_width = 416;
  c.max_candidates = 0;
  expectError([&] { YoloDetector{c}; }, {"max_candidates", "0"});
  c.max_candidates = 1000;
  c.labels = {"box_end", "drill_bit"};
  expectError([&] { YoloDetector{c}; }, {"labels[1]", "drill_bit"});
  fs::remove_all(d);
}

// ---------------------------------------------------------------------------------------------
// The shipped model on rendered images of the thesis rig (held-out simulator seed), at the node's
// default input (the colour image's native size): every end visible to a camera is found with
// IoU >= 0.5 and the right label, upright (thesis_vertical) and tilted by 30.6 deg
// (thesis_angled; see models/detector/README.md).
TEST(ShippedModel, DetectsBothEndsInRenderedThesisImages) {
  ASSERT_TRUE(fs::exists(kModel)) << kModel;
  DetectorConfig c;
  c.model = kModel;
  c.labels = readLabelsFile(kSource + "/models/detector/labels.txt");
  EXPECT_EQ(c.input_width, 960);
  EXPECT_EQ(c.input_height, 544);
  YoloDetector det(c);
  EXPECT_EQ(det.layout().format, OutputFormat::kGrid);
  EXPECT_EQ(det.layout().num_classes, 2);

  for (const auto& [scene, min_fraction] : std::vector<std::pair<std::string, double>>{
           {"thesis_vertical", 1.0}, {"thesis_angled", 1.0}}) {
    sim::SimulatorOptions opt;
    opt.profile = "kinect_v2_calibrated";
    opt.seed = 4242;  // not a training seed
    opt.color = true;
    opt.sensor_config_dir = kSource + "/config/sensors";
    opt.detector.edge_jitter_px = 0;
    opt.detector.miss_probability = 0;
    opt.detector.swap_probability = 0;
    opt.detector.duplicate_probability = 0;
    opt.detector.false_positive_probability = 0;
    const auto sim = sim::loadScenario(kSource + "/config/rigs/thesis_lab.yaml",
                                       kSource + "/config/scenes/" + scene + ".yaml", opt);
    int matched = 0, expected = 0;
    for (size_t cam = 0; cam < sim->numCameras(); ++cam) {
      auto frame = sim->render(cam, 0.0, 0);
      const cv::Mat img(static_cast<int>(frame.color_height), static_cast<int>(frame.color_width),
                        CV_8UC3, frame.bgr.data());
      const auto dets = det.detect(img);
      for (const DetectionBox& gt : frame.sensor_frame.boxes) {
        ++expected;
        float best = 0;
        for (const DetectionBox& d : dets)
          if (d.label == gt.label)
            best = std::max(best, iou(box(0, 1, d.x_min, d.y_min, d.x_max, d.y_max),
                                      box(0, 1, gt.x_min, gt.y_min, gt.x_max, gt.y_max)));
        if (min_fraction >= 1.0) {
          EXPECT_GE(best, 0.5f) << scene << " " << sim->cameraName(cam) << " "
                                << labelName(gt.label) << " truth [" << gt.x_min << ", " << gt.y_min
                                << ", " << gt.x_max << ", " << gt.y_max << "]";
        }
        if (best >= 0.5f) ++matched;
      }
    }
    EXPECT_GE(expected, 6) << scene;  // 6 cameras x 2 ends, minus occlusions
    EXPECT_GE(matched, min_fraction * expected) << scene;
    std::printf("shipped model, %s: %d / %d ends matched (IoU >= 0.5)\n", scene.c_str(), matched,
                expected);
  }
}
