// simulate_bag: renders a scenario into a bag, faster than real time, with a progress bar.
//
//   rosrun drill_pipe_pose simulate_bag --scene config/scenes/thesis_vertical.yaml --out X.bag
//       [--rig config/rigs/thesis_lab.yaml] [--duration 10] [--start 0] [--profile NAME]
//       [--seed 1] [--no-detection | --true-boxes] [--miss-probability P] [--swap-probability P]
//       [--color] [--crop] [--sensors config/sensors]
//       [--quiet]
//       [--effect-off EFFECT]... [--model fitted|before-fit|additive] [--true-rig FILE]
//       [--hd-mono] [--fps N]
//       [--published-rig FILE] [--detector-model FILE [--detector-param KEY=VALUE]...]
//       [--no-amplitude] [--grow-box CAM:LABEL:PX]...
//
// Each SensorFrame carries the IR amplitude image of its depth (the sensor model's amplitude in
// the Kinect v2's digital numbers, cropped with the depth; with --color also on
// <cam>/sd/image_ir_rect); --no-amplitude leaves it out, as a driver without one. --grow-box
// makes one camera's simulated boxes of one label PX colour pixels taller at the top, in every
// frame (a biased detector: one camera that must not pull the pose).
// --crop sends each SensorFrame's depth cropped to its boxes' frustum (roi), as a bandwidth-saving
// sensor node does: bags are ~100x smaller and the estimator's poses are the same.
// The bag (LZ4) carries what the estimator needs: <cam>/sensor_frame (SensorFrame, simulated
// detections unless --no-detection), /tf_static (latched), /ground_truth/<end> and, once at the
// start, /ground_truth/joints (each scored joint's OD as rendered, its wear included). --color
// adds the kinect2_bridge-style camera topics (QHD colour ~1.5 MB per frame: keep such bags short).
// --effect-off switches one of the profile's sensor effects off (repeatable; the names are
// SensorEffects' fields: axial_noise, lateral_noise, depth_offset, flying_pixels, ...), to
// measure what each costs the estimator. --model chooses the sensor model: fitted (the profile
// as it is), before-fit (the model before its fit to real Kinect v2 frames: white noise, no
// amplitude effects, lateral noise on every pixel; bit-identical to that model's frames), or
// additive (the fitted weak-return noise added to the literature's range law,
// sqrt(sigma_z^2 + (C / a)^2), instead of the larger of the two: the other reading of the fit
// beyond its 1.5 m of data). --true-rig writes the rig file of the truth (RigSimulator::trueRig):
// the rendered extrinsics and each camera's depth_scale and depth_offset, the offset including the
// weak-return brightness bias at the rig's range (what a depth calibration there would find), for
// scoring a calibration or running the estimator (parameter rig) with perfect corrections.
// --hd-mono writes what the rig calibration records (launch/calibrate.launch) instead of the
// SensorFrames: per camera the HD grey image <cam>/hd/image_mono_rect (mono8, from colour rendered
// at 1920x1080) with <cam>/hd/camera_info, and <cam>/sd/image_depth_rect with <cam>/sd/camera_info
// (about 2.3 MB per frame before compression: use it with --fps). --fps N keeps every k-th capture
// of each camera, k = round(frame rate / N) (N frames per second per camera), as a recorder that
// throttles does; the other captures are not rendered. Without these two flags the bag is the same
// as before they existed.
// --true-boxes: the SensorFrames' boxes are the exact visible silhouettes (the simulated detector
// with every error rate at zero, as render_dataset labels), to score labels against
// (label_from_poses --score-against, scripts/bench_labels).
// --published-rig puts another rig file's world -> <cam>_link into /tf_static (a calibration's
// result: the cameras render from their true poses and the estimator fuses with the calibrated).
// --detector-model runs the real detector in the loop in one pass (issue 22): colour is rendered
// in memory, each frame goes as kinect2_bridge-style messages through the pipe_detector node's
// frame assembly (ros/detector_frames.hpp, the same code as the node and detect_bag, with the
// node's parameters and defaults; --detector-param KEY=VALUE sets any of them, --crop sets
// crop_depth) and only its SensorFrames are written: a 10 s six-camera scene stays a bag of about
// 40 MB with --crop, where the same scene with --color is about 4 GB (0.42 GB per second of six
// cameras, LZ4; measured with thesis_vertical) before detect_bag could read it: the one-pass route
// keeps the bench far below 2 GB of disk. The SensorFrames are the ones
// `simulate_bag --color --no-detection` followed by `detect_bag` gives (a test checks it); the
// simulated detector is off, the depth frames are those of the same seed without it.
// Exit status 0; 1 on bad input files or an unwritable bag; 2 on a bad command line.
#include <drill_pipe_pose/SensorFrame.h>
#include <ros/package.h>
#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/detector_frames.hpp"
#include "drill_pipe_pose/ros/sim_messages.hpp"
#include "sim_cli.hpp"

using namespace drill_pipe_pose;

namespace {

void progress(double done, double total, double rate, bool quiet) {
  if (quiet) return;
  const int width = 30, n = static_cast<int>(width * done / total);
  std::fprintf(stderr, "\r[%.*s%*s] %5.1f%%  %.1f / %.1f s  %.1f six-camera frames/s", n,
               "##############################", width - n, "", 100.0 * done / total, done, total,
               rate);
  std::fflush(stderr);
}

/// The rig's static TF at scenario time `start` [s], latched like
/// tf2_ros::StaticTransformBroadcaster's; world -> <cam>_link from `published` when given (a
/// calibrated rig file: what rig_tf_publisher would send), else the simulator's published poses.
/// Returns the message written.
tf2_msgs::TFMessage writeStaticTf(const sim::RigSimulator& sim, double start,
                                  const RigCalibration* published, rosbag::Bag* bag) {
  tf2_msgs::TFMessage tf_static;
  tf_static.transforms = simStaticTransforms(sim);
  for (size_t i = 0; published && i < sim.numCameras(); ++i) {
    const int c = published->find(sim.cameraName(i));
    if (c < 0) fail("--published-rig: camera ", sim.cameraName(i), " is not in the rig file");
    for (auto& t : tf_static.transforms)
      if (t.child_frame_id == conventions::linkFrame(sim.cameraName(i)))
        t.transform = toTransformMsg(published->cameras[c].T_world_link, t.header.frame_id,
                                     t.child_frame_id, t.header.stamp)
                          .transform;
  }
  auto latched = boost::make_shared<std::map<std::string, std::string>>();
  (*latched)["type"] = ros::message_traits::datatype<tf2_msgs::TFMessage>();
  (*latched)["md5sum"] = ros::message_traits::md5sum<tf2_msgs::TFMessage>();
  (*latched)["message_definition"] = ros::message_traits::definition<tf2_msgs::TFMessage>();
  (*latched)["callerid"] = "/simulate_bag";
  (*latched)["latching"] = "1";
  bag->write("/tf_static", fromNs(sim.stampNs(start)), tf_static, latched);
  return tf_static;
}

/// One camera's detections of one label made taller at the top (a biased detector).
struct BoxGrowth {
  std::string camera;
  EndLabel label = EndLabel::kBoxEnd;
  float top_px = 0.0f;  ///< [colour px] y_min moves up by this
};

/// "CAM:LABEL:PX" -> a BoxGrowth; throws InputError naming the text.
BoxGrowth parseBoxGrowth(const std::string& text) {
  const size_t a = text.find(':'), b = text.rfind(':');
  if (a == std::string::npos || b == a)
    fail("--grow-box ", text, ": expected CAM:LABEL:PX, e.g. cam2:box_end:9");
  BoxGrowth g;
  g.camera = text.substr(0, a);
  g.label = parseEndLabel(text.substr(a + 1, b - a - 1), "--grow-box " + text);
  try {
    g.top_px = std::stof(text.substr(b + 1));
  } catch (const std::exception&) {
    fail("--grow-box ", text, ": PX must be a number of pixels");
  }
  if (g.camera.empty() || !(g.top_px >= 0.0f && g.top_px < 1e4f))
    fail("--grow-box ", text, ": expected a camera name and 0 <= PX < 10000");
  return g;
}

struct FrameOptions {
  bool crop = false;     ///< SensorFrames' depth cropped to their boxes' frustum
  bool write_color = false;  ///< the kinect2_bridge-style colour and depth topics too
  /// With a detector: the SensorFrames are the pipe_detector node's on the rendered colour.
  OfflineDetector* detector = nullptr;
  bool quiet = false;    ///< no progress bar
  bool hd_mono = false;  ///< the calibration's topics instead of SensorFrames
  uint64_t every = 1;    ///< keep every k-th capture of each camera
  std::vector<BoxGrowth> grow;  ///< detections made taller (--grow-box)
};

/// Every `every`-th capture of each camera in [start, start + duration).
std::vector<sim::Capture> keptCaptures(const sim::RigSimulator& sim, double start,
                                       double duration, uint64_t every) {
  std::vector<sim::Capture> out;
  for (const sim::Capture& c : sim.captures(start, start + duration))
    if (c.frame_index % every == 0) out.push_back(c);
  return out;
}

/// The pipe_detector node's SensorFrame for a rendered frame: the kinect2_bridge-style messages
/// that --color writes, through the same frame assembly as detect_bag (so that both give the same
/// frames); nothing when the detector's max_rate skips the frame.
std::optional<SensorFrameData> detectRendered(const sim::RigSimulator& sim, size_t camera,
                                              const sim::RigSimulator::Frame& frame,
                                              OfflineDetector* detector) {
  KinectTopics k = simKinectTopics(sim, camera, frame);
  const std::string& cam = sim.cameraName(camera);
  sensor_msgs::ImagePtr color, depth;
  const sensor_msgs::CameraInfo *color_info = nullptr, *depth_info = nullptr;
  sensor_msgs::ImagePtr amplitude;
  for (auto& [topic, img] : k.images)
    (topic == conventions::colorImageTopic(cam)       ? color
     : topic == conventions::amplitudeImageTopic(cam) ? amplitude
                                                      : depth) =
        boost::make_shared<sensor_msgs::Image>(std::move(img));
  for (const auto& [topic, info] : k.infos)
    (topic == conventions::colorInfoTopic(cam) ? color_info : depth_info) = &info;
  if (!color || !depth || !color_info || !depth_info)
    fail("camera ", cam, ": the rendered frame has no colour image (internal error)");
  return detector->process(cam, color, *color_info, depth, *depth_info, "", amplitude);
}

/// Renders the captures in [start, start + duration) into the bag (SensorFrames, cropped with
/// `crop`; the colour topics with the simulator's colour option; or with `hd_mono` only the
/// calibration's topics; ground truth), with a progress bar unless `quiet`. Returns the frames
/// written.
size_t writeFrames(sim::RigSimulator& sim, double start, double duration, const FrameOptions& o,
                   rosbag::Bag* bag) {
  const auto captures = keptCaptures(sim, start, duration, o.every);
  const auto wall0 = std::chrono::steady_clock::now();
  size_t done = 0;
  for (const auto& c : captures) {
    sim::RigSimulator::Frame frame = sim.render(c.camera, c.t, c.frame_index);
    for (const BoxGrowth& g : o.grow)
      if (g.camera == sim.cameraName(c.camera))
        for (DetectionBox& b : frame.sensor_frame.boxes)
          if (b.label == g.label) b.y_min = std::max(0.0f, b.y_min - g.top_px);
    const ros::Time stamp = fromNs(frame.sensor_frame.stamp_ns);
    const std::string& cam = sim.cameraName(c.camera);
    if (o.hd_mono) {
      const KinectTopics k = simCalibrationTopics(sim, c.camera, frame);
      for (const auto& [topic, img] : k.images) bag->write("/" + topic, stamp, img);
      for (const auto& [topic, info] : k.infos) bag->write("/" + topic, stamp, info);
    } else if (o.detector) {
      if (const auto sf = detectRendered(sim, c.camera, frame, o.detector))
        bag->write("/" + conventions::sensorFrameTopic(cam), stamp, toMsg(*sf));
    } else {
      const SensorFrameData& sf =
          o.crop ? cropDepthToBoxes(frame.sensor_frame, sim.T_link_depth(c.camera))
                 : frame.sensor_frame;
      bag->write("/" + conventions::sensorFrameTopic(cam), stamp, toMsg(sf));
    }
    if (o.write_color && !o.hd_mono) {
      const KinectTopics k = simKinectTopics(sim, c.camera, frame);
      for (const auto& [topic, img] : k.images) bag->write("/" + topic, stamp, img);
      for (const auto& [topic, info] : k.infos) bag->write("/" + topic, stamp, info);
    }
    for (const auto& [topic, pose] : simGroundTruth(sim, c.t)) bag->write(topic, stamp, pose);
    if (++done % 30 == 0 || done == captures.size()) {
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
      progress(c.t - start, duration, done / (double)sim.numCameras() / std::max(wall, 1e-9),
               o.quiet);
    }
  }
  return done;
}

/// Opens `path` for writing, LZ4-compressed.
void openBag(const std::string& path, rosbag::Bag* bag) {
  try {
    bag->open(path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    fail("cannot write bag '", path, "': ", e.what());
  }
  bag->setCompression(rosbag::compression::LZ4);
}

/// What --hd-mono needs: colour at the Kinect v2's HD resolution, no simulated detections.
void renderForCalibration(sim::SimulatorOptions* opt) {
  opt->color = true;
  opt->color_scale = 2;
  opt->simulated_detection = false;
}

/// Writes the simulated rig's truth as a rig file (RigSimulator::trueRig).
void writeTrueRig(const sim::RigSimulator& sim, const std::string& path) {
  std::ofstream f(path);
  f << "# The true rig of a simulate_bag run (" << sim.options().profile << ", seed "
    << sim.options().seed << "): world -> <cam>_link as rendered;\n"
    << "# depth_offset includes the weak-return brightness bias at the rig's range\n"
    << "# (RigSimulator::effectiveDepthOffset).\n"
    << rigCalibrationToYaml(sim.trueRig());
  if (!f) fail("cannot write the true rig file '", path, "'");
}

/// The sensor model's options (profile, seed, sensor files, bumps, effects off, model).
struct ModelArgs {
  std::vector<std::string> effects_off, bumps, sensor_params;
  std::string model = "fitted";
};

void addModelOptions(CLI::App& app, sim::SimulatorOptions* opt, ModelArgs* m) {
  app.add_option("--profile", opt->profile,
                 "sensor profile: ideal|kinect_v2_calibrated|kinect_v2_field|"
                 "kinect_v2_uncalibrated")
      ->capture_default_str()
      ->check(tools::throwingCheck("PROFILE", [](const std::string& v) { sim::sensorProfile(v); }));
  app.add_option("--seed", opt->seed, "random seed of the simulation")->capture_default_str();
  app.add_option("--sensors", opt->sensor_config_dir, "folder of the sensor intrinsics files")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
  app.add_option("--bump", m->bumps,
                 "move camera CAM's true pose at time T [s] by DX,DY,DZ [m] (and ROLL,PITCH,YAW "
                 "[deg]) in its <cam>_link (x right, y down, z along the view) while the "
                 "published TF stays (a bumped camera; repeatable)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->expected(1)
      ->option_text("CAM:T:DX,DY,DZ[:ROLL,PITCH,YAW] ...")
      ->check(tools::throwingCheck("BUMP", [](const std::string& v) { sim::parseCameraBump(v); }));
  app.add_option("--pipe-type", opt->pipe_type,
                 "every pipe of the scene takes this pipe catalogue entry's geometry "
                 "(config/pipe_catalog.yaml, e.g. 5.5in_FH_7.0od); a lying pipe stays on its "
                 "support (its axis moves with the tool-joint radius)");
  tools::addEffectOffOption(app, "--effect-off", &m->effects_off,
                            "switch one of the profile's sensor effects off by name (repeatable)");
  tools::addSensorParamOption(
      app, "--sensor-param", &m->sensor_params,
      "set one numeric sensor parameter of the profile (repeatable), e.g. "
      "lateral_noise_px=0.8 (the edge model before its fit to real frames: docs/sensor_check.md)");
  app.add_option("--model", m->model,
                 "sensor model: fitted, before-fit (as before the fit to real frames), additive "
                 "(the weak-return noise added to the range law) or edges-before-refit (the edge "
                 "model before its fit to a real board's silhouette)")
      ->capture_default_str()
      ->check(CLI::IsMember({"fitted", "before-fit", "additive", "edges-before-refit"}));
}

/// Applies the parsed ModelArgs to the simulator's options.
void applyModelArgs(const ModelArgs& m, sim::SimulatorOptions* opt) {
  if (!m.effects_off.empty() || !m.sensor_params.empty() || m.model != "fitted") {
    sim::SensorEffects fx = sim::sensorProfile(opt->profile);
    if (m.model == "before-fit") sim::useModelBeforeFit(&fx);
    if (m.model == "edges-before-refit") sim::useEdgeModelBeforeRefit(&fx);
    fx.amplitude_noise_additive = m.model == "additive";
    for (const std::string& e : m.effects_off) sim::switchOffEffect(&fx, e);
    for (const std::string& p : m.sensor_params) sim::setEffectParameter(&fx, p);
    opt->effects = fx;
  }
  for (const std::string& b : m.bumps) opt->bumps.push_back(sim::parseCameraBump(b));
}

/// --detector-model and --detector-param.
void addDetectorOptions(CLI::App& app, std::string* model, std::vector<std::string>* params) {
  auto* det_model =
      app.add_option("--detector-model", *model,
                     "run the real detector (this model, e.g. models/detector/pipe_yolo.onnx) on "
                     "colour rendered in memory and write the pipe_detector node's SensorFrames "
                     "(one pass: no colour in the bag unless --color)")
          ->check(CLI::ExistingFile)
          ->excludes("--hd-mono");
  app.add_option("--detector-param", *params,
                 "with --detector-model: set one pipe_detector parameter, e.g. "
                 "confidence_threshold=0.3 (repeatable; docs/parameters.md)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->option_text("KEY=VALUE")
      ->needs(det_model)
      ->check(tools::throwingCheck("KEY=VALUE", [](const std::string& kv) {
        PipeDetectorNodeConfig scratch;
        const size_t eq = kv.find('=');
        if (eq == std::string::npos || eq == 0) fail("expected KEY=VALUE, got '", kv, "'");
        applyParamString(pipeDetectorParamTable(), &scratch, kv.substr(0, eq), kv.substr(eq + 1),
                         "--detector-param");
      }));
}

/// The pipe_detector node's parameters for --detector-model: the node's defaults, the model,
/// crop_depth from --crop, then every --detector-param.
PipeDetectorNodeConfig detectorParams(const std::string& model,
                                      const std::vector<std::string>& params, bool crop) {
  PipeDetectorNodeConfig p;
  p.detector.model = model;
  p.crop_depth = crop;
  for (const std::string& kv : params) {
    const size_t eq = kv.find('=');
    applyParamString(pipeDetectorParamTable(), &p, kv.substr(0, eq), kv.substr(eq + 1),
                     "--detector-param");
  }
  return p;
}

/// The simulated detector's options: none, exact boxes, or a heavier error model.
void addSimulatedDetectorOptions(CLI::App& app, sim::SimulatorOptions* o) {
  app.add_flag_function("--no-detection", [o](int64_t) { o->simulated_detection = false; },
                        "send no simulated detections (boxes) in the SensorFrames");
  app.add_flag_function(
         "--true-boxes",
         [o](int64_t) {
           o->detector.edge_jitter_px = 0.0;
           o->detector.miss_probability = 0.0;
           o->detector.swap_probability = 0.0;
           o->detector.duplicate_probability = 0.0;
           o->detector.false_positive_probability = 0.0;
         },
         "the SensorFrames' boxes are the exact visible silhouettes (no detector errors), to "
         "score labels against")
      ->excludes("--no-detection");
  app.add_option("--miss-probability", o->detector.miss_probability,
                 "simulated detector: probability that an end is missed in a camera frame "
                 "(a heavier error model for the estimator's input)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0))
      ->excludes("--true-boxes");
  app.add_option("--swap-probability", o->detector.swap_probability,
                 "simulated detector: probability of a box_end <-> pin_end label swap")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0))
      ->excludes("--true-boxes");
}

}  // namespace

int main(int argc, char** argv) {
  const std::string pkg = ros::package::getPath("drill_pipe_pose");
  std::string scene, out, rig = pkg + "/config/rigs/thesis_lab.yaml", true_rig, published_rig;
  double duration = 10.0, start = 0.0;
  FrameOptions fo;
  double fps = 0.0;
  ModelArgs model_args;
  std::string detector_model;
  std::vector<std::string> detector_params;
  sim::SimulatorOptions opt;
  opt.sensor_config_dir = pkg + "/config/sensors";
  opt.stamp_origin_ns = 1000000000;  // t = 0 at ROS time 1 s (0 means "latest" to tf2)
  CLI::App app{"Renders a scenario into a bag (SensorFrames, /tf_static, ground truth), faster "
               "than real time.",
               "simulate_bag"};
  tools::configureApp(app);
  app.add_option("--scene", scene, "scenario file (YAML), e.g. config/scenes/thesis_vertical.yaml")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--out", out, "bag to write")->required();
  app.add_option("--rig", rig, "rig calibration file (YAML)")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
  app.add_option("--published-rig", published_rig,
                 "publish world -> <cam>_link from this rig file instead of the simulated one (a "
                 "calibrated rig: render with the true poses, fuse with the calibrated ones)")
      ->check(CLI::ExistingFile);
  app.add_option("--true-rig", true_rig,
                 "also write the rig file of the truth: the true world -> <cam>_link and each "
                 "camera's true depth_scale and depth_offset, the offset including the weak-return "
                 "brightness bias every surface at the rig's range reads (which a depth "
                 "calibration there absorbs; +28.5 mm in kinect_v2_uncalibrated). Give it to the "
                 "estimator (rig) for perfect depth corrections, or score a calibration with it");
  app.add_option("--duration", duration, "[s] simulated time to render")
      ->capture_default_str()
      ->check(CLI::Range(1e-3, 86400.0));
  app.add_option("--start", start, "[s] scenario time of the first frame")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 86400.0));
  addSimulatedDetectorOptions(app, &opt);
  auto* color = app.add_flag(
      "--color", opt.color,
      "also write the kinect2_bridge-style colour and depth topics (large bags)");
  app.add_flag("--hd-mono", fo.hd_mono,
               "write what the rig calibration records instead of SensorFrames: the HD grey "
               "image and its camera_info, the SD depth image and its camera_info (large bags: "
               "use --fps)")
      ->excludes(color);
  app.add_option("--fps", fps,
                 "frames per second per camera to keep (every k-th capture, k = round(frame "
                 "rate / fps)); default: every capture")
      ->check(CLI::PositiveNumber);
  app.add_flag("--crop", fo.crop,
               "crop each SensorFrame's depth to its boxes' frustum (~100x smaller)");
  app.add_flag("--quiet", fo.quiet, "no progress bar");
  std::vector<std::string> grow;
  app.add_option("--grow-box", grow,
                 "CAM:LABEL:PX: that camera's simulated boxes of that label PX colour pixels "
                 "taller at the top (a biased detector; repeatable)");
  app.add_flag_function(
      "--no-amplitude", [&opt](int64_t) { opt.amplitude = false; },
      "SensorFrames without the IR amplitude image (as from a driver that publishes none)");
  addDetectorOptions(app, &detector_model, &detector_params);
  addModelOptions(app, &opt, &model_args);
  tools::parseOrExit(app, argc, argv);
  try {
    applyModelArgs(model_args, &opt);
    for (const std::string& g : grow) fo.grow.push_back(parseBoxGrowth(g));
    if (fo.hd_mono) renderForCalibration(&opt);
    fo.write_color = opt.color;
    std::optional<OfflineDetector> detector;
    if (!detector_model.empty()) {
      detector.emplace(detectorParams(detector_model, detector_params, fo.crop), detector_model);
      opt.color = true;                  // rendered for the detector, written only with --color
      opt.simulated_detection = false;  // the real detector's boxes instead
      fo.detector = &*detector;
    }
    auto simulator = sim::loadScenario(rig, scene, opt);
    sim::RigSimulator& sim = *simulator;
    if (fps > 0)
      fo.every = static_cast<uint64_t>(
          std::max(1.0, std::round(sim.sensor(0).frame_rate_hz / fps)));
    rosbag::Bag bag;
    openBag(out, &bag);
    std::cerr << "simulate_bag: " << sim.numCameras() << " cameras, scene " << scene << ", profile "
              << opt.profile << ", seed " << opt.seed << ", " << duration << " s -> " << out
              << "\n";

    std::optional<RigCalibration> published;
    if (!published_rig.empty()) published = loadRigCalibration(published_rig);
    const tf2_msgs::TFMessage tf_static =
        writeStaticTf(sim, start, published ? &*published : nullptr, &bag);
    if (detector)
      for (const auto& t : tf_static.transforms) detector->addTf(t, true);
    if (!true_rig.empty()) writeTrueRig(sim, true_rig);
    bag.write(conventions::kGroundTruthJointsTopic, fromNs(sim.stampNs(start)),
              simTrueJoints(sim));

    const auto wall0 = std::chrono::steady_clock::now();
    const size_t frames = writeFrames(sim, start, duration, fo, &bag);
    bag.close();
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    if (!fo.quiet) std::fprintf(stderr, "\n");
    std::printf(
        "simulate_bag: wrote %zu frames (%.1f s of %zu cameras) in %.1f s: %.2f six-camera "
        "frames per second\n",
        frames, duration, sim.numCameras(), wall, frames / 6.0 / std::max(wall, 1e-9));
    if (detector)
      std::printf("simulate_bag: detector %s: %zu frames, %zu box_end and %zu pin_end boxes, "
                  "%.1f ms per frame\n",
                  detector_model.c_str(), detector->frames(), detector->boxes(EndLabel::kBoxEnd),
                  detector->boxes(EndLabel::kPinEnd),
                  detector->detectorMs() / std::max<size_t>(detector->frames(), 1));
  } catch (const InputError& e) {
    std::cerr << "\nsimulate_bag: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
