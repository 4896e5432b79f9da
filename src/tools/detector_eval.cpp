// detector_eval: accuracy and speed of a detector model (core YoloDetector, as the pipe_detector
// node runs it).
//
//   detector_eval --model M.onnx --data DIR/yolo [--split test] [--input 416x416]
//       [--roi x,y,w,h] [--conf 0.01] [--max-per-class 0] [--cross-class-nms 0.7]
//       [--labels box_end,pin_end]
//       [--darknet-cfg C.cfg] [--threads 1] [--csv OUT.csv] [--min-ap A]
//     mAP@0.5 per class (VOC all-point interpolated AP; a detection matches an unmatched ground
//     truth box of its class with IoU >= 0.5, highest score first) over a YOLO dataset, e.g.
//     images render_dataset rendered with held-out seeds. Also precision / recall at the node's
//     operating point (confidence 0.25, one box per class), of every box at that confidence
//     (the node's max_boxes_per_class unlimited), and the mean time per image.
//   detector_eval --model M.onnx --timing 320x320,416x416,512x512,640x384 [--image I.jpg]
//       [--repeat 20] [--threads 1]
//     Inference time against input size (median / mean [ms] per frame, preprocessing + network +
//     decoding), on one core by default, at the node's operating point (confidence 0.25, one box
//     per class, unless --conf / --max-per-class say otherwise).
// Exit status 0; 1 on bad input; 2 on a bad command line, or when --min-ap is given and a class
// falls below it.
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "drill_pipe_pose/core/detector/yolo_detector.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "cli.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::detector;
namespace fs = std::filesystem;

namespace {

struct Options {
  DetectorConfig det;  ///< for --data: confidence 0.01, no per-class limit unless given
  DetectorConfig timing_det;  ///< for --timing: the node's operating point unless given
  std::string data, split = "test", timing, image, csv;
  int repeat = 20;
  double min_ap = -1.0;
};

std::vector<std::string> splitList(const std::string& s, char sep = ',') {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

/// "WIDTHxHEIGHT" -> width, height (positive); throws InputError otherwise.
void parseSize(const std::string& s, int* w, int* h) {
  const auto v = splitList(s, 'x');
  size_t used_w = 0, used_h = 0;
  try {
    if (v.size() == 2) {
      *w = std::stoi(v[0], &used_w);
      *h = std::stoi(v[1], &used_h);
    }
  } catch (const std::exception&) {
    used_w = used_h = 0;
  }
  if (v.size() != 2 || used_w != v[0].size() || used_h != v[1].size() || *w <= 0 || *h <= 0)
    fail("size '", s, "': expected WIDTHxHEIGHT, e.g. 416x416");
}

/// "x,y,w,h" (pixels, whole numbers >= 0) -> roi; throws InputError otherwise.
ImageRoi parseRoi(const std::string& s) {
  const auto v = splitList(s);
  ImageRoi roi;
  unsigned long x[4] = {0, 0, 0, 0};
  bool ok = v.size() == 4;
  for (size_t i = 0; ok && i < 4; ++i) {
    size_t used = 0;
    try {
      ok = v[i][0] != '-' && (x[i] = std::stoul(v[i], &used), used == v[i].size()) && x[i] < 100000;
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok) fail("roi '", s, "': expected x,y,width,height in pixels, e.g. 0,0,960,540");
  roi.x_offset = x[0];
  roi.y_offset = x[1];
  roi.width = x[2];
  roi.height = x[3];
  return roi;
}

Options parseArgs(int argc, char** argv) {
  Options o;
  std::string input, roi, labels;
  CLI::App app{"Accuracy (mAP@0.5 over a YOLO dataset) and speed (inference time against input "
               "size) of a detector model, as the pipe_detector node runs it.",
               "detector_eval"};
  tools::configureApp(app);
  app.footer(
      "Give --data (accuracy) or --timing (speed), or both. Exit status 0; 1 on bad input; 2 on a "
      "bad command line or when --min-ap is given and a class falls below it.");
  app.add_option("--model", o.det.model, "model file: .onnx, or Darknet .weights")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--darknet-cfg", o.det.darknet_cfg,
                 "Darknet .cfg of a .weights model (default: beside it)")
      ->check(CLI::ExistingFile);
  app.add_option("--data", o.data, "YOLO dataset folder (render_dataset's DIR/yolo): accuracy")
      ->check(CLI::ExistingDirectory);
  app.add_option("--split", o.split, "dataset split to evaluate")->capture_default_str();
  app.add_option("--input", input, "network input size [px], multiples of 32 (default: 960x544)")
      ->option_text("WxH")
      ->check(tools::throwingCheck("WxH", [](const std::string& v) {
        int w, h;
        parseSize(v, &w, &h);
      }));
  app.add_option("--roi", roi, "region of interest of the colour image [px] (default: whole image)")
      ->option_text("x,y,w,h")
      ->check(tools::throwingCheck("x,y,w,h", [](const std::string& v) { parseRoi(v); }));
  app.add_option("--conf", o.det.confidence_threshold,
                 "confidence threshold (default: 0.01 for --data, 0.25 for --timing)")
      ->check(CLI::Range(0.0f, 1.0f));
  app.add_option("--max-per-class", o.det.max_boxes_per_class,
                 "boxes kept per class, 0 = no limit (default: 0 for --data, 1 for --timing)")
      ->check(CLI::Range(0, 100000));
  app.add_option("--cross-class-nms", o.det.cross_class_nms_threshold,
                 "IoU above which a box of the other class is suppressed (>= 1: off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--labels", labels, "class names in the model's order, comma-separated")
      ->option_text("box_end,pin_end");
  app.add_option("--threads", o.det.num_threads, "threads for inference (0: OpenCV's default)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  app.add_option("--timing", o.timing, "input sizes to time, comma-separated: speed")
      ->option_text("WxH,...")
      ->check(tools::throwingCheck("WxH,...", [](const std::string& v) {
        const auto sizes = splitList(v);
        if (sizes.empty()) fail("expected WxH,..., e.g. 320x320,416x416");
        int w, h;
        for (const auto& s : sizes) parseSize(s, &w, &h);
      }));
  app.add_option("--image", o.image, "image to time on (default: random 960x540 pixels)")
      ->check(CLI::ExistingFile);
  app.add_option("--repeat", o.repeat, "timed runs per input size")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--csv", o.csv, "write the results to this CSV file");
  app.add_option("--min-ap", o.min_ap, "exit 2 when a class's AP@0.5 is below this (--data)")
      ->check(CLI::Range(0.0, 1.0));
  tools::parseOrExit(app, argc, argv);
  if (o.data.empty() && o.timing.empty())
    tools::usageError(app, "give --data (accuracy) or --timing (speed)");
  if (!input.empty()) parseSize(input, &o.det.input_width, &o.det.input_height);
  if (!roi.empty()) o.det.roi = parseRoi(roi);
  if (!labels.empty()) o.det.labels = splitList(labels);
  const bool conf_given = app.count("--conf") > 0, max_given = app.count("--max-per-class") > 0;
  // mAP needs the whole precision-recall curve; --timing keeps the node's operating point.
  o.timing_det = o.det;
  if (!conf_given) o.det.confidence_threshold = 0.01f;
  if (!max_given) o.det.max_boxes_per_class = 0;
  return o;
}

struct GroundTruth {
  int cls;
  ScoredBox box;
};

std::vector<GroundTruth> readYoloLabels(const fs::path& path, int width, int height) {
  std::vector<GroundTruth> out;
  std::ifstream f(path);
  int c;
  float x, y, w, h;
  while (f >> c >> x >> y >> w >> h) {
    GroundTruth g;
    g.cls = c;
    g.box.x_min = (x - w / 2) * width;
    g.box.x_max = (x + w / 2) * width;
    g.box.y_min = (y - h / 2) * height;
    g.box.y_max = (y + h / 2) * height;
    out.push_back(g);
  }
  return out;
}

/// VOC all-point interpolated average precision.
double averagePrecision(std::vector<std::pair<float, int>> scored, int n_gt) {
  if (n_gt == 0) return std::nan("");
  std::sort(scored.begin(), scored.end(), [](auto& a, auto& b) { return a.first > b.first; });
  std::vector<double> rec, prec;
  double tp = 0, fp = 0;
  for (const auto& [s, t] : scored) {
    (t ? tp : fp) += 1;
    rec.push_back(tp / n_gt);
    prec.push_back(tp / (tp + fp));
  }
  std::vector<double> mrec{0.0}, mpre{1.0};
  mrec.insert(mrec.end(), rec.begin(), rec.end());
  mpre.insert(mpre.end(), prec.begin(), prec.end());
  mrec.push_back(1.0);
  mpre.push_back(0.0);
  for (int i = static_cast<int>(mpre.size()) - 2; i >= 0; --i)
    mpre[i] = std::max(mpre[i], mpre[i + 1]);
  double ap = 0;
  for (size_t i = 1; i < mrec.size(); ++i) ap += (mrec[i] - mrec[i - 1]) * mpre[i];
  return ap;
}

int evaluate(const Options& o) {
  const fs::path img_dir = fs::path(o.data) / "images" / o.split;
  const fs::path lab_dir = fs::path(o.data) / "labels" / o.split;
  if (!fs::is_directory(img_dir))
    fail("detector_eval: no image folder '", img_dir.string(), "' (a YOLO dataset: images/",
         o.split, ", labels/", o.split, ")");
  std::vector<fs::path> images;
  for (const auto& e : fs::directory_iterator(img_dir)) {
    const std::string ext = e.path().extension().string();
    if (ext == ".jpg" || ext == ".png" || ext == ".jpeg") images.push_back(e.path());
  }
  std::sort(images.begin(), images.end());
  if (images.empty()) fail("detector_eval: '", img_dir.string(), "' holds no images");
  YoloDetector det(o.det);
  const int nc = det.layout().num_classes;
  std::vector<std::vector<std::pair<float, int>>> scored(nc);
  std::vector<int> n_gt(nc, 0), op_tp(nc, 0), op_fp(nc, 0), all_tp(nc, 0), all_fp(nc, 0);
  double total_ms = 0, net_ms = 0;
  for (const fs::path& p : images) {
    const cv::Mat img = cv::imread(p.string(), cv::IMREAD_COLOR);
    if (img.empty()) fail("detector_eval: cannot read image '", p.string(), "'");
    std::vector<GroundTruth> gts =
        readYoloLabels(lab_dir / (p.stem().string() + ".txt"), img.cols, img.rows);
    // Ground truth outside the roi cannot be detected: it does not count.
    if (!o.det.roi.isFull()) {
      const ImageRoi& r = o.det.roi;
      gts.erase(std::remove_if(gts.begin(), gts.end(),
                               [&](const GroundTruth& g) {
                                 const float cx = (g.box.x_min + g.box.x_max) / 2;
                                 const float cy = (g.box.y_min + g.box.y_max) / 2;
                                 return cx < r.x_offset || cy < r.y_offset ||
                                        cx > r.x_offset + r.width || cy > r.y_offset + r.height;
                               }),
                gts.end());
    }
    for (const GroundTruth& g : gts)
      if (g.cls >= 0 && g.cls < nc) ++n_gt[g.cls];
    const std::vector<ScoredBox> dets = det.detectRaw(img);
    total_ms += det.lastTiming().total();
    net_ms += det.lastTiming().inference_ms;
    std::vector<bool> used(gts.size(), false);
    // Operating point: confidence >= 0.25, best box per class.
    std::vector<bool> op_seen(nc, false);
    for (const ScoredBox& d : dets) {  // sorted by score
      float best = 0.5f;
      int bj = -1;
      for (size_t j = 0; j < gts.size(); ++j) {
        if (gts[j].cls != d.class_id || used[j]) continue;
        const float v = iou(d, gts[j].box);
        if (v >= best) {
          best = v;
          bj = static_cast<int>(j);
        }
      }
      if (bj >= 0) used[bj] = true;
      scored[d.class_id].push_back({d.score, bj >= 0 ? 1 : 0});
      if (d.score >= 0.25f && !op_seen[d.class_id]) {
        op_seen[d.class_id] = true;
        (bj >= 0 ? op_tp : op_fp)[d.class_id]++;
      }
      // Every box at the confidence, as with max_boxes_per_class unlimited (several ends of a
      // class in view): what raising the node's max_boxes_per_class would let through.
      if (d.score >= 0.25f) (bj >= 0 ? all_tp : all_fp)[d.class_id]++;
    }
  }
  std::printf("detector_eval: %zu images of %s (split %s), model %s, input %dx%d, roi %s\n",
              images.size(), o.data.c_str(), o.split.c_str(), o.det.model.c_str(),
              o.det.input_width, o.det.input_height,
              o.det.roi.isFull()
                  ? "whole image"
                  : (std::to_string(o.det.roi.x_offset) + "," + std::to_string(o.det.roi.y_offset) +
                     "," + std::to_string(o.det.roi.width) + "," + std::to_string(o.det.roi.height))
                        .c_str());
  int rc = 0;
  double sum = 0;
  std::ofstream csv;
  if (!o.csv.empty()) {
    csv.open(o.csv);
    csv << "class,label,ground_truth,ap50,precision_at_0.25_top1,recall_at_0.25_top1,"
           "precision_at_0.25_all,recall_at_0.25_all\n";
  }
  for (int c = 0; c < nc; ++c) {
    const double ap = averagePrecision(scored[c], n_gt[c]);
    const std::string name = c < static_cast<int>(o.det.labels.size()) ? o.det.labels[c] : "?";
    const double prec = op_tp[c] + op_fp[c] > 0 ? double(op_tp[c]) / (op_tp[c] + op_fp[c]) : 0.0;
    const double rec = n_gt[c] > 0 ? double(op_tp[c]) / n_gt[c] : 0.0;
    const double all_prec =
        all_tp[c] + all_fp[c] > 0 ? double(all_tp[c]) / (all_tp[c] + all_fp[c]) : 0.0;
    const double all_rec = n_gt[c] > 0 ? double(all_tp[c]) / n_gt[c] : 0.0;
    std::printf(
        "  %-8s AP@0.5 %.3f  (%d ground-truth boxes; at confidence 0.25, best box per "
        "class: precision %.3f, recall %.3f; every box: precision %.3f, recall %.3f)\n",
        name.c_str(), ap, n_gt[c], prec, rec, all_prec, all_rec);
    if (csv)
      csv << c << "," << name << "," << n_gt[c] << "," << ap << "," << prec << "," << rec << ","
          << all_prec << "," << all_rec << "\n";
    sum += std::isnan(ap) ? 0 : ap;
    if (o.min_ap >= 0 && !(ap >= o.min_ap)) rc = 2;
  }
  std::printf("  mAP@0.5 %.3f; mean time per image %.1f ms (network %.1f ms), %d thread(s)\n",
              sum / nc, total_ms / images.size(), net_ms / images.size(), o.det.num_threads);
  return rc;
}

int timing(const Options& o) {
  cv::Mat img;
  if (!o.image.empty()) {
    img = cv::imread(o.image, cv::IMREAD_COLOR);
    if (img.empty()) fail("detector_eval: cannot read image '", o.image, "'");
  } else {
    img = cv::Mat(540, 960, CV_8UC3);
    cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(255));
  }
  std::printf(
      "detector_eval: inference time vs input size, model %s, %d thread(s), image %dx%d, "
      "roi %s, %d runs each\n",
      o.det.model.c_str(), o.det.num_threads, img.cols, img.rows,
      o.det.roi.isFull() ? "whole image" : "set", o.repeat);
  std::printf("  confidence threshold %.2f, at most %d box(es) per class\n",
              o.timing_det.confidence_threshold, o.timing_det.max_boxes_per_class);
  std::printf("  %-10s %10s %10s %10s %10s\n", "input", "median_ms", "mean_ms", "network_ms",
              "pre+post");
  std::ofstream csv;
  if (!o.csv.empty()) {
    csv.open(o.csv);
    csv << "input_width,input_height,median_ms,mean_ms,network_ms\n";
  }
  for (const std::string& s : splitList(o.timing)) {
    DetectorConfig c = o.timing_det;
    parseSize(s, &c.input_width, &c.input_height);
    c.allow_upscale = true;
    YoloDetector det(c);
    det.detectRaw(img);  // warm-up
    std::vector<double> t;
    double net = 0, other = 0;
    for (int i = 0; i < o.repeat; ++i) {
      det.detectRaw(img);
      t.push_back(det.lastTiming().total());
      net += det.lastTiming().inference_ms;
      other += det.lastTiming().preprocess_ms + det.lastTiming().postprocess_ms;
    }
    std::vector<double> sorted = t;
    std::sort(sorted.begin(), sorted.end());
    double mean = 0;
    for (double v : t) mean += v;
    mean /= t.size();
    std::printf("  %-10s %10.1f %10.1f %10.1f %10.1f\n", s.c_str(), sorted[sorted.size() / 2], mean,
                net / o.repeat, other / o.repeat);
    if (csv)
      csv << c.input_width << "," << c.input_height << "," << sorted[sorted.size() / 2] << ","
          << mean << "," << net / o.repeat << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parseArgs(argc, argv);
    int rc = 0;
    if (!o.data.empty()) rc = evaluate(o);
    if (!o.timing.empty()) rc = std::max(rc, timing(o));
    return rc;
  } catch (const std::exception& e) {
    std::cerr << "detector_eval: " << e.what() << "\n";
    return 1;
  }
}
