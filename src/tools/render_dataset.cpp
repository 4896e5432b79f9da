// render_dataset: renders labelled colour images of a rig with the simulator and writes a YOLO
// dataset and a Pascal VOC dataset (the labels are the exact visible silhouettes of the tool
// joints: the simulated detector with every error rate at zero).
//
//   render_dataset --out DIR [--random N | --scene S.yaml ...] [--frames K] [--seed N]
//       [--rig RIG.yaml] [--cameras cam1,cam3] [--profile kinect_v2_calibrated] [--split train]
//       [--format both|yolo|voc] [--augment A] [--negatives 0.2] [--jpeg-quality 92]
//       [--print-roi] [--quiet]
//
// --random N: N random scenarios (seeded by --seed and the scenario index): lighting (direction,
//   ambient), paint (yellow, grey, bare dark steel, rust, colour variations), mud, room materials
//   and clutter (background), both ends at random positions over the work zone (the thesis rig's
//   distances and beyond), tilt 0-90 deg, hanging pin-ends, sometimes a whole horizontal pipe or
//   a distractor; each scenario renders K poses (--frames) seen by every camera.
// --scene S.yaml (repeatable): the given scenario files instead, at K times spread over 120 s
//   (the moving / random-pose scenes change over that span). Use held-out --seed values for
//   evaluation sets.
// --augment A: A extra copies of each image with the thesis's augmentations (random translation,
//   scale, horizontal mirror), boxes transformed and clipped.
// --print-roi: prints, per camera, the colour-image rectangle of the scene's work zone (for the
//   pipe_detector's ~roi parameter) and exits.
//
// Layout: DIR/yolo/{images,labels}/<split>/<name>.{jpg,txt} (class cx cy w h, normalised),
// DIR/yolo/classes.txt, DIR/yolo/<split>.txt (image list); DIR/voc/JPEGImages/<name>.jpg,
// DIR/voc/Annotations/<name>.xml, DIR/voc/ImageSets/Main/<split>.txt.
// Exit status 0; 1 on bad input files; 2 on a bad command line.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <random>
#include <sstream>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/detector/dataset_writer.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"
#include "drill_pipe_pose/sim/sensor_model.hpp"
#include "cli.hpp"

#ifndef DRILL_PIPE_POSE_SOURCE_DIR
#define DRILL_PIPE_POSE_SOURCE_DIR "."
#endif

using namespace drill_pipe_pose;

namespace {

struct Options {
  std::string out, rig = std::string(DRILL_PIPE_POSE_SOURCE_DIR) + "/config/rigs/thesis_lab.yaml";
  std::string sensors = std::string(DRILL_PIPE_POSE_SOURCE_DIR) + "/config/sensors";
  std::vector<std::string> scenes, cameras;
  int random = 0, frames = 4, augment = 0, jpeg_quality = 92;
  uint32_t seed = 1;
  std::string profile = "kinect_v2_calibrated", split = "train", format = "both";
  double negatives = 0.2;
  double drill_floor = 0.0;
  bool print_roi = false, quiet = false;
};

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

Options parseArgs(int argc, char** argv) {
  Options o;
  std::string cameras;
  CLI::App app{"Renders labelled colour images of a rig with the simulator into a YOLO and a "
               "Pascal VOC dataset.",
               "render_dataset"};
  tools::configureApp(app);
  app.add_option("--out", o.out, "output folder (required unless --print-roi)");
  app.add_option("--random", o.random, "render N random scenarios (the default: 1, unless --scene)")
      ->check(CLI::Range(0, 1000000));
  app.add_option("--scene", o.scenes, "render this scenario file instead (repeatable)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->expected(1)
      ->option_text("S.yaml ...")
      ->check(CLI::ExistingFile);
  app.add_option("--frames", o.frames, "poses rendered per scenario")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--seed", o.seed, "random seed (use held-out seeds for evaluation sets)")
      ->capture_default_str();
  app.add_option("--rig", o.rig, "rig calibration file (YAML)")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
  app.add_option("--sensors", o.sensors, "folder of the sensor intrinsics files")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
  app.add_option("--cameras", cameras, "only these cameras, comma-separated (default: all)")
      ->option_text("cam1,cam2");
  app.add_option("--profile", o.profile,
                 "sensor profile: ideal|kinect_v2_calibrated|kinect_v2_field|"
                 "kinect_v2_uncalibrated")
      ->capture_default_str()
      ->check(tools::throwingCheck("PROFILE", [](const std::string& v) { sim::sensorProfile(v); }));
  app.add_option("--split", o.split, "dataset split the images go to (train, val, test, ...)")
      ->capture_default_str();
  app.add_option("--format", o.format, "datasets to write")
      ->capture_default_str()
      ->check(CLI::IsMember({"both", "yolo", "voc"}));
  app.add_option("--augment", o.augment,
                 "augmented copies of each image (translation, scale, mirror)")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  app.add_option("--negatives", o.negatives,
                 "fraction of images without a tool joint that are kept")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--drill-floor", o.drill_floor,
                 "fraction of the random scenarios that also hold a drill floor's stump: a box "
                 "end standing in slips on a rotary table, sometimes a pin end hanging over it")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--jpeg-quality", o.jpeg_quality, "JPEG quality of the images")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  app.add_flag("--print-roi", o.print_roi,
               "print each camera's colour-image rectangle of the work zone and exit");
  app.add_flag("--quiet", o.quiet, "no progress line");
  tools::parseOrExit(app, argc, argv);
  if (o.out.empty() && !o.print_roi)
    tools::usageError(app, "--out is required (unless --print-roi)");
  o.cameras = splitList(cameras);
  if (o.random <= 0 && o.scenes.empty()) o.random = 1;
  return o;
}

/// A drill floor's stump as scene-file YAML `objects` and `pipes` entries (empty: none).
struct Stump {
  std::string objects, pipes;
};

/// With probability `fraction`, a stump: a box end standing upright in slips on a rotary table
/// (random heights, radii and materials; the stabbing and drill-floor set-ups), in half of them
/// a pin end hanging over it. Its own generator (seeded by the scenario), so that the random
/// scenarios' other draws stay the same with or without it. The ranges bracket the stabbing
/// scene's (rotary table r 0.6 m, 0.25 m high; slips r 0.18 m, 0.45 m; box face 0.8 m up; pin
/// nose 0.25 m above it, 3 cm off axis): modelled, not tuned.
Stump drillFloorStump(double fraction, uint32_t scenario_seed) {
  std::mt19937 rng(scenario_seed * 2654435761u + 97u);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  auto uni = [&](double a, double b) { return a + (b - a) * U(rng); };
  Stump st;
  if (fraction <= 0 || U(rng) >= fraction) return st;
  const std::vector<std::string> steel = {"dark_steel", "rusty_steel", "catwalk_steel",
                                          "black_rubber", "grey_paint"};
  auto pick = [&]() { return steel[static_cast<size_t>(U(rng) * steel.size()) % steel.size()]; };
  const double x = uni(3.5, 5.9), y = uni(4.8, 7.3);
  const double table_h = uni(0.1, 0.35), slips_h = table_h + uni(0.15, 0.4);
  const double face = slips_h + uni(0.2, 0.6);  // [m] the box face above the floor
  std::ostringstream o, p;
  o << "  - {name: rotary_table, type: cylinder, radius: " << uni(0.45, 0.8)
    << ", height: " << table_h << ", pose: {translation: [" << x << ", " << y
    << ", 0.0], rpy_deg: [0, 0, 0]}, material: " << pick() << "}\n";
  o << "  - {name: slips, type: cylinder, radius: " << uni(0.13, 0.25) << ", height: " << slips_h
    << ", pose: {translation: [" << x << ", " << y << ", 0.0], rpy_deg: [0, 0, 0]}, material: "
    << pick() << "}\n";
  p << "  - {name: stump, type: tool_joint, end: box_end, tube_length: 1.0, pose: {translation: ["
    << x << ", " << y << ", " << face << "], rpy_deg: [0, 0, " << uni(0, 360)
    << "]}, material: paint" << static_cast<int>(uni(0, 3)) << "}\n";
  if (U(rng) < 0.5) {
    const double a = uni(0, 2 * M_PI), off = uni(0.0, 0.08);
    p << "  - {name: hoisted, type: tool_joint, end: pin_end, tube_length: " << uni(1.0, 3.0)
      << ", pose: {translation: [" << x + off * std::cos(a) << ", " << y + off * std::sin(a)
      << ", " << face + uni(0.25, 1.2) << "], z_axis: [0, 0, -1]}, material: paint"
      << static_cast<int>(uni(0, 3)) << "}\n";
  }
  st.objects = o.str();
  st.pipes = p.str();
  return st;
}

/// A random scenario as scene-file YAML (the simulator's own schema); with `drill_floor` > 0
/// sometimes a drill floor's stump too (drillFloorStump).
std::string randomScenario(std::mt19937& rng, int frames, uint32_t scenario_seed,
                           double drill_floor) {
  const Stump stump = drillFloorStump(drill_floor, scenario_seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  auto uni = [&](double a, double b) { return a + (b - a) * U(rng); };
  auto pick = [&](const std::vector<std::string>& v) {
    return v[static_cast<size_t>(U(rng) * v.size()) % v.size()];
  };
  auto jitterBgr = [&](int b, int g, int r, double amount) {
    std::ostringstream s;
    auto j = [&](int c) {
      return std::clamp(static_cast<int>(c * uni(1 - amount, 1 + amount)), 0, 255);
    };
    s << "[" << j(b) << ", " << j(g) << ", " << j(r) << "]";
    return s.str();
  };
  std::ostringstream y;
  y << "name: random_" << scenario_seed << "\n";
  y << "work_zone: {min: [2.7, 4.0, 0.0], max: [6.7, 8.1, 3.0]}\n";
  // Room and lighting.
  y << "room: {size: [10.0, 10.0, 5.5], floor: floor_m, walls: wall_m}\n";
  y << "light: {direction: [" << uni(-0.8, 0.8) << ", " << uni(-0.8, 0.8)
    << ", -1], ambient: " << uni(0.15, 0.65) << "}\n";
  y << "materials:\n";
  const std::vector<std::array<int, 3>> floors = {{150, 152, 155}, {90, 95, 100},  {60, 70, 80},
                                                  {170, 170, 160}, {110, 120, 95}, {40, 45, 50}};
  const auto f = floors[static_cast<size_t>(U(rng) * floors.size()) % floors.size()];
  y << "  floor_m: {reflectivity: 0.4, bgr: " << jitterBgr(f[0], f[1], f[2], 0.2) << "}\n";
  const std::vector<std::array<int, 3>> walls = {
      {205, 208, 210}, {160, 170, 180}, {120, 140, 100}, {180, 150, 120}, {90, 90, 90}};
  const auto w = walls[static_cast<size_t>(U(rng) * walls.size()) % walls.size()];
  y << "  wall_m: {reflectivity: 0.6, bgr: " << jitterBgr(w[0], w[1], w[2], 0.2) << "}\n";
  // Paint of the tool joints: yellow (the thesis), grey, bare dark steel, rust, variations.
  const std::vector<std::array<int, 3>> paints = {{20, 195, 230},  {20, 195, 230}, {30, 170, 215},
                                                  {120, 120, 125}, {60, 62, 66},   {40, 70, 115},
                                                  {25, 140, 200},  {80, 85, 90}};
  for (int i = 0; i < 3; ++i) {
    const auto p = paints[static_cast<size_t>(U(rng) * paints.size()) % paints.size()];
    y << "  paint" << i << ": {reflectivity: " << uni(0.1, 0.65)
      << ", bgr: " << jitterBgr(p[0], p[1], p[2], 0.15) << "}\n";
  }
  const std::vector<std::string> clutter_mats = {"barrel_blue",   "cardboard",    "hi_vis",
                                                 "catwalk_steel", "black_rubber", "grey_paint",
                                                 "concrete",      "rusty_steel"};
  // Clutter (background objects) near the work zone.
  const int n_clutter = static_cast<int>(uni(0, 7));
  if (n_clutter > 0 || !stump.objects.empty()) y << "objects:\n";
  y << stump.objects;
  for (int i = 0; i < n_clutter; ++i) {
    const double x = uni(2.7, 6.7), yy = uni(4.0, 8.1), yaw = uni(0, 180);
    if (U(rng) < 0.5) {
      const double sx = uni(0.2, 1.2), sy = uni(0.2, 1.2), sz = uni(0.2, 1.5);
      y << "  - {name: c" << i << ", type: box, size: [" << sx << ", " << sy << ", " << sz
        << "], pose: {translation: [" << x << ", " << yy << ", " << sz / 2 << "], rpy_deg: [0, 0, "
        << yaw << "]}, material: " << pick(clutter_mats) << "}\n";
    } else {
      y << "  - {name: c" << i << ", type: cylinder, radius: " << uni(0.08, 0.4)
        << ", height: " << uni(0.3, 1.9) << ", pose: {translation: [" << x << ", " << yy
        << ", 0.0], rpy_deg: [0, 0, 0]}, material: " << pick(clutter_mats) << "}\n";
    }
  }
  // The tool joints: one box-end and one pin-end lab sample moving through random poses.
  y << "pipes:\n" << stump.pipes;
  const double cx = uni(3.9, 5.5), cy = uni(5.2, 6.9);
  const bool mud = U(rng) < 0.6;
  for (int e = 0; e < 2; ++e) {
    const std::string end = e == 0 ? "box_end" : "pin_end";
    const double tilt_max = U(rng) < 0.4 ? 20.0 : 90.0;
    y << "  - name: " << end << "_sample\n    type: tool_joint\n    end: " << end
      << "\n    pose: {translation: [4.7, 6.0, 0.5], rpy_deg: [0, 0, 0]}\n"
      << "    material: paint" << (U(rng) < 0.7 ? 0 : e + 1)
      << "\n    mud: " << (mud ? "true" : "false") << "\n    tube_length: " << uni(0.15, 1.5)
      << "\n"
      << "    motion:\n      random_poses: {count: " << frames
      << ", interval_s: 1.0, seed: " << scenario_seed * 2 + e << ", centre: [" << cx << ", " << cy
      << "], half_extent: [1.3, 1.3], tilt_deg: [0, " << tilt_max
      << "], hanging_fraction: 0.3, clearance: [0.0, 1.6], min_separation: 0.8}\n";
  }
  // Sometimes a whole pipe lying (catwalk-like) or a second, distractor pipe.
  if (U(rng) < 0.35) {
    const double a = uni(0, 2 * M_PI);
    y << "  - name: whole_pipe\n    type: pipe\n    length: " << uni(2.0, 5.0)
      << "\n    pose: {translation: [" << uni(3.0, 6.4) << ", " << uni(4.3, 7.8) << ", "
      << uni(0.084, 1.2) << "], z_axis: [" << std::cos(a) << ", " << std::sin(a) << ", "
      << uni(-0.15, 0.15) << "]}\n    material: paint" << static_cast<int>(uni(0, 3)) << "\n";
  }
  return y.str();
}

/// The dataset writer (core/detector/dataset_writer.hpp) with the thesis's augmentations.
struct Writer {
  Options o;
  DatasetWriter out;
  std::mt19937 aug_rng;

  explicit Writer(const Options& opt)
      : o(opt), out(writerOptions(opt)), aug_rng(opt.seed * 7919u + 17u) {}

  static DatasetWriterOptions writerOptions(const Options& opt) {
    DatasetWriterOptions w;
    w.out = opt.out;
    w.split = opt.split;
    w.format = opt.format;
    w.jpeg_quality = opt.jpeg_quality;
    return w;
  }

  void write(const std::string& name, const cv::Mat& img, const std::vector<DetectionBox>& bs) {
    out.write(name, img, bs);
  }

  /// The thesis's augmentations: translate, scale, mirror (boxes follow; clipped; boxes with
  /// less than 40 % of their area left are dropped).
  void writeAugmented(const std::string& name, const cv::Mat& img,
                      const std::vector<DetectionBox>& bs) {
    std::uniform_real_distribution<double> U(0.0, 1.0);
    const double s = 0.7 + 0.6 * U(aug_rng);
    const double tx = (U(aug_rng) - 0.5) * 0.4 * img.cols, ty = (U(aug_rng) - 0.5) * 0.4 * img.rows;
    const bool mirror = U(aug_rng) < 0.5;
    // x' = s (x - c) + c + t, then mirrored: x'' = W - x'.
    const double cx = img.cols / 2.0, cy = img.rows / 2.0;
    cv::Mat M = (cv::Mat_<double>(2, 3) << s, 0, (1 - s) * cx + tx, 0, s, (1 - s) * cy + ty);
    if (mirror) {
      M.at<double>(0, 0) = -s;
      M.at<double>(0, 2) = img.cols - ((1 - s) * cx + tx);
    }
    cv::Mat out;
    cv::warpAffine(img, out, M, img.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                   cv::Scalar(114, 114, 114));
    std::vector<DetectionBox> ob;
    for (DetectionBox b : bs) {
      double x0 = M.at<double>(0, 0) * b.x_min + M.at<double>(0, 2);
      double x1 = M.at<double>(0, 0) * b.x_max + M.at<double>(0, 2);
      if (x0 > x1) std::swap(x0, x1);
      const double y0 = s * b.y_min + M.at<double>(1, 2), y1 = s * b.y_max + M.at<double>(1, 2);
      const double area = (x1 - x0) * (y1 - y0);
      const double cx0 = std::clamp(x0, 0.0, double(img.cols)),
                   cx1 = std::clamp(x1, 0.0, double(img.cols));
      const double cy0 = std::clamp(y0, 0.0, double(img.rows)),
                   cy1 = std::clamp(y1, 0.0, double(img.rows));
      if (area <= 0 || (cx1 - cx0) * (cy1 - cy0) < 0.4 * area) continue;
      b.x_min = static_cast<float>(cx0);
      b.x_max = static_cast<float>(cx1);
      b.y_min = static_cast<float>(cy0);
      b.y_max = static_cast<float>(cy1);
      ob.push_back(b);
    }
    write(name, out, ob);
  }
};

void renderScenario(Writer& w, const RigCalibration& rig, const sim::SceneConfig& scene,
                    const std::string& tag, uint32_t sim_seed, double t0, double dt,
                    const Options& o, std::mt19937& rng) {
  sim::SimulatorOptions opt;
  opt.profile = o.profile;
  opt.seed = sim_seed;
  opt.color = true;
  opt.simulated_detection = true;
  opt.sensor_config_dir = o.sensors;
  opt.stamp_origin_ns = 1000000000LL;
  opt.detector.edge_jitter_px = 0.0;
  opt.detector.miss_probability = 0.0;
  opt.detector.swap_probability = 0.0;
  opt.detector.duplicate_probability = 0.0;
  opt.detector.false_positive_probability = 0.0;
  sim::RigSimulator sim(rig, scene, opt);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (int k = 0; k < o.frames; ++k) {
    const double t = t0 + k * dt;
    for (size_t c = 0; c < sim.numCameras(); ++c) {
      const std::string& cam = sim.cameraName(c);
      if (!o.cameras.empty() &&
          std::find(o.cameras.begin(), o.cameras.end(), cam) == o.cameras.end())
        continue;
      sim::RigSimulator::Frame f = sim.render(c, t, static_cast<uint64_t>(k));
      const std::vector<DetectionBox>& bs = f.sensor_frame.boxes;
      if (bs.empty() && U(rng) >= o.negatives) continue;
      const cv::Mat img(static_cast<int>(f.color_height), static_cast<int>(f.color_width), CV_8UC3,
                        f.bgr.data());
      char name[160];
      std::snprintf(name, sizeof(name), "%s_f%03d_%s", tag.c_str(), k, cam.c_str());
      w.write(name, img, bs);
      for (int a = 0; a < o.augment; ++a)
        w.writeAugmented(std::string(name) + "_aug" + std::to_string(a), img, bs);
    }
  }
}

void printRoi(const RigCalibration& rig, const std::string& scene_path, const Options& o) {
  sim::SimulatorOptions opt;
  opt.sensor_config_dir = o.sensors;
  opt.simulated_detection = false;
  const auto sim = sim::loadScenario(o.rig, scene_path, opt);
  const sim::WorkZone& z = sim->workZone();
  (void)rig;
  for (size_t c = 0; c < sim->numCameras(); ++c) {
    const PinholeCamera cam = PinholeCamera::fromCameraInfo(sim->colorInfo(c), "colour");
    const Eigen::Isometry3d T_color_world = sim->trueT_world_link(c).inverse();
    double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d p((i & 1) ? z.max.x() : z.min.x(), (i & 2) ? z.max.y() : z.min.y(),
                              (i & 4) ? z.max.z() : z.min.z());
      Eigen::Vector2d uv;
      if (!cam.project(T_color_world * p, &uv)) continue;
      u0 = std::min(u0, uv.x());
      v0 = std::min(v0, uv.y());
      u1 = std::max(u1, uv.x());
      v1 = std::max(v1, uv.y());
    }
    const int x = std::clamp(static_cast<int>(std::floor(u0)), 0, int(cam.imageWidth()) - 1);
    const int y = std::clamp(static_cast<int>(std::floor(v0)), 0, int(cam.imageHeight()) - 1);
    const int x1 = std::clamp(static_cast<int>(std::ceil(u1)), x + 1, int(cam.imageWidth()));
    const int y1 = std::clamp(static_cast<int>(std::ceil(v1)), y + 1, int(cam.imageHeight()));
    std::printf(
        "%s: roi [%d, %d, %d, %d]  (x, y, width, height of the work zone in the %ux%u "
        "colour image)\n",
        sim->cameraName(c).c_str(), x, y, x1 - x, y1 - y, cam.imageWidth(), cam.imageHeight());
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parseArgs(argc, argv);
    const RigCalibration rig = loadRigCalibration(o.rig);
    if (o.print_roi) {
      for (const std::string& s :
           o.scenes.empty() ? std::vector<std::string>{std::string(DRILL_PIPE_POSE_SOURCE_DIR) +
                                                       "/config/scenes/thesis_vertical.yaml"}
                            : o.scenes)
        printRoi(rig, s, o);
      return 0;
    }
    Writer w(o);
    std::mt19937 rng(o.seed);
    const auto start = std::chrono::steady_clock::now();
    const size_t total = o.scenes.empty() ? static_cast<size_t>(o.random) : o.scenes.size();
    for (size_t i = 0; i < total; ++i) {
      if (o.scenes.empty()) {
        const uint32_t sseed = o.seed * 100000u + static_cast<uint32_t>(i);
        const std::string yaml = randomScenario(rng, o.frames, sseed, o.drill_floor);
        const sim::SceneConfig scene =
            sim::parseSceneConfig(yaml, "random scenario " + std::to_string(sseed));
        char tag[64];
        std::snprintf(tag, sizeof(tag), "s%u_r%05zu", o.seed, i);
        renderScenario(w, rig, scene, tag, sseed, 0.5, 1.0, o, rng);
      } else {
        const sim::SceneConfig scene = sim::loadSceneConfig(o.scenes[i]);
        char tag[128];
        std::snprintf(tag, sizeof(tag), "s%u_%s", o.seed, scene.name.c_str());
        renderScenario(w, rig, scene, tag, o.seed, 0.25, 120.0 / o.frames, o, rng);
      }
      if (!o.quiet) {
        const double el =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::fprintf(stderr, "\rscenario %zu / %zu, %zu images, %zu box_end, %zu pin_end, %.0f s",
                     i + 1, total, w.out.images(), w.out.boxes(EndLabel::kBoxEnd),
                     w.out.boxes(EndLabel::kPinEnd), el);
      }
    }
    if (!o.quiet) std::fprintf(stderr, "\n");
    std::printf("render_dataset: %zu images (%zu box_end, %zu pin_end boxes) in %s\n",
                w.out.images(), w.out.boxes(EndLabel::kBoxEnd), w.out.boxes(EndLabel::kPinEnd),
                o.out.c_str());
  } catch (const std::exception& e) {
    std::cerr << "render_dataset: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
