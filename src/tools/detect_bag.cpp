// detect_bag: the pipe_detector node on a recording, without ROS transport. Reads a bag of
// kinect2_bridge-style camera topics (per camera <cam>/qhd/image_color_rect, <cam>/qhd/camera_info,
// <cam>/sd/image_depth_rect, <cam>/sd/camera_info, as `simulate_bag --color --no-detection` writes
// them or a real rig records them, plus /tf_static), pairs colour and depth as the node does
// (message_filters' ApproximateTime on the capture stamps, the node's sync_slop and queue), runs
// the node's frame assembly (detector boxes, depth cropped to them with --crop: the same function
// as the node, ros/detector_frames.hpp) on every pair and writes the SensorFrames the node would
// publish (<cam>/sensor_frame, stamped with the colour capture time), copying /tf_static, /tf and
// /ground_truth/* through. `bench_estimator OUT` then scores the whole chain. The IR amplitude
// (<cam>/sd/image_ir_rect, the node's amplitude_topic), when recorded, goes into each SensorFrame
// of the same depth stamp, cropped with its depth.
//
//   rosrun drill_pipe_pose detect_bag IN.bag --out OUT.bag [--crop] [--model FILE]
//       [--config FILE] [--param KEY=VALUE]... [--camera CAM]... [--quiet]
//
// Detector configuration, in this order: the node's defaults (docs/parameters.md, pipe_detector
// table: the same names and defaults); --config (a YAML file of those parameters, as the node
// loads them); the shortcuts --model and --crop; every --param. The node's max_rate applies on
// the same capture-time grid (default 0: every frame); tf_timeout does not (the bag's TF is all
// there is). With --crop and no colour <- depth transform in the bag's TF, the depth goes out
// full, as in the node, with a warning. Colour bags are large (about 0.42 GB per second of six
// cameras); for simulated scenes, simulate_bag --detector-model gives the same SensorFrames in one
// pass without writing the colour.
// Exit status 0; 1 on a bad bag, model or frame (the message names the file, topic or camera); 2
// on a bad command line.
#include <drill_pipe_pose/SensorFrame.h>
#include <ros/package.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

#include <chrono>
#include <cmath>
#include <deque>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "cli.hpp"
#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/detector_frames.hpp"

using namespace drill_pipe_pose;

namespace {

using sensor_msgs::CameraInfo;
using sensor_msgs::CameraInfoConstPtr;
using sensor_msgs::Image;
using sensor_msgs::ImageConstPtr;

struct Options {
  std::string in, out, config;
  std::vector<std::string> cameras;
  bool quiet = false;
  /// key=value settings in the order they apply: the shortcuts', then --param's.
  std::vector<std::pair<std::string, std::string>> shortcuts, params;
};

/// Checks a KEY=VALUE against the pipe_detector parameter table while the command line is parsed,
/// so that a bad one exits 2 naming the option.
void checkParam(const std::string& option, const std::string& key, const std::string& value) {
  PipeDetectorNodeConfig scratch;
  try {
    applyParamString(pipeDetectorParamTable(), &scratch, key, value, option);
  } catch (const InputError& e) {
    throw CLI::ValidationError(option, e.what());
  }
}

Options parseArgs(int argc, char** argv) {
  Options o;
  CLI::App app{"Runs the pipe_detector node's frame assembly (YOLO boxes, depth crop) on every "
               "colour + depth frame of a bag of camera topics and writes the SensorFrames it "
               "would publish, with the bag's TF and ground truth, for bench_estimator.",
               "detect_bag"};
  tools::configureApp(app);
  app.footer(
      "Configuration: the pipe_detector node's defaults, then --config, then --model / --crop, "
      "then every --param (any key of the pipe_detector parameter table, docs/parameters.md).");
  app.add_option("BAG", o.in,
                 "bag with <cam>/qhd/image_color_rect, <cam>/qhd/camera_info, "
                 "<cam>/sd/image_depth_rect, <cam>/sd/camera_info and /tf_static")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--out", o.out, "bag of SensorFrames to write")->required();
  app.add_option("--config", o.config,
                 "YAML file of pipe_detector parameters (what the node loads)")
      ->check(CLI::ExistingFile);
  app.add_option_function<std::string>(
      "--model",
      [&o](const std::string& v) {
        checkParam("--model", "model", v);
        o.shortcuts.emplace_back("model", v);
      },
      "detector model (.onnx or Darknet .weights); default: models/detector/pipe_yolo.onnx "
      "(--param model=FILE)")
      ->check(CLI::ExistingFile);
  app.add_flag_function(
      "--crop", [&o](int64_t) { o.shortcuts.emplace_back("crop_depth", "true"); },
      "send each frame's depth cropped to its boxes' frustum (--param crop_depth=true)");
  tools::addKeyValueOption(app, "--param", &o.params, checkParam,
                           "set one pipe_detector parameter, e.g. confidence_threshold=0.3 "
                           "(repeatable)");
  app.add_option("--camera", o.cameras,
                 "only this camera (repeatable; default: every camera with colour topics)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app.add_flag("--quiet", o.quiet, "no progress output");
  tools::parseOrExit(app, argc, argv);
  return o;
}

/// The node's parameters for this run: defaults, --config, shortcuts, --param.
PipeDetectorNodeConfig makeParams(const Options& o) {
  PipeDetectorNodeConfig p;
  if (!o.config.empty()) applyParamYaml(pipeDetectorParamTable(), &p, o.config);
  for (const auto& [key, value] : o.shortcuts)
    applyParamString(pipeDetectorParamTable(), &p, key, value, "detect_bag");
  for (const auto& [key, value] : o.params)
    applyParamString(pipeDetectorParamTable(), &p, key, value, "--param");
  checkParamRanges(pipeDetectorParamTable(), p, "detect_bag");
  return p;
}

/// "cam1/qhd/image_color_rect" -> "cam1"; "" when `topic` is no colour image topic.
std::string cameraOfColorTopic(std::string topic) {
  if (!topic.empty() && topic.front() == '/') topic.erase(0, 1);
  const std::string suffix = conventions::colorImageTopic("");
  if (topic.size() <= suffix.size() ||
      topic.compare(topic.size() - suffix.size(), suffix.size(), suffix) != 0)
    return "";
  return topic.substr(0, topic.size() - suffix.size());
}

/// The cameras of the bag: every <cam> with a colour image topic (or those asked for), each with
/// its four topics present and of the right type. Throws InputError naming the bag, the camera
/// and the topic.
std::vector<std::string> bagCameras(const rosbag::Bag& bag, const Options& o) {
  std::map<std::string, std::string> types;  // topic -> datatype
  rosbag::View all(bag);
  for (const rosbag::ConnectionInfo* c : all.getConnections()) {
    std::string t = c->topic;
    if (!t.empty() && t.front() != '/') t = "/" + t;
    types[t] = c->datatype;
  }
  std::set<std::string> found;
  for (const auto& [topic, type] : types)
    if (const std::string cam = cameraOfColorTopic(topic); !cam.empty()) found.insert(cam);
  if (found.empty())
    fail("bag '", o.in, "' has no colour image topic <cam>/", conventions::colorImageTopic(""),
         " (record the kinect2_bridge topics, or simulate_bag --color --no-detection)");
  std::vector<std::string> cams(found.begin(), found.end());
  if (!o.cameras.empty()) {
    for (const std::string& c : o.cameras)
      if (!found.count(c))
        fail("--camera ", c, ": bag '", o.in, "' has no topic /", conventions::colorImageTopic(c));
    cams = o.cameras;
  }
  for (const std::string& cam : cams) {
    const std::pair<std::string, const char*> need[] = {
        {conventions::colorImageTopic(cam), "sensor_msgs/Image"},
        {conventions::colorInfoTopic(cam), "sensor_msgs/CameraInfo"},
        {conventions::depthImageTopic(cam), "sensor_msgs/Image"},
        {conventions::depthInfoTopic(cam), "sensor_msgs/CameraInfo"}};
    for (const auto& [topic, type] : need) {
      const auto it = types.find("/" + topic);
      if (it == types.end())
        fail("bag '", o.in, "', camera ", cam, ": topic /", topic, " is missing");
      if (it->second != type)
        fail("bag '", o.in, "', camera ", cam, ": topic /", topic, " is ", it->second,
             ", expected ", type);
    }
  }
  return cams;
}

bool isPassThrough(const std::string& topic) {
  return topic == "/tf_static" || topic == "/tf" || topic.rfind("/ground_truth/", 0) == 0;
}

/// Progress on stderr: colour frames read of total, frames per second, detector time per frame.
void progress(size_t done, size_t total, double wall_s, double detector_ms, size_t frames) {
  const int width = 30, n = total ? static_cast<int>(width * done / total) : width;
  std::fprintf(stderr,
               "\r[%.*s%*s] %5.1f%%  %zu / %zu colour frames  %.1f frames/s  detector %.1f ms", n,
               "##############################", width - n, "",
               total ? 100.0 * done / total : 100.0, done, total, done / std::max(wall_s, 1e-9),
               frames ? detector_ms / frames : 0.0);
  std::fflush(stderr);
}

/// The run: per camera the node's synchroniser feeding one OfflineDetector, the output bag.
class BagDetector {
 public:
  BagDetector(const Options& o, const PipeDetectorNodeConfig& params,
              const std::vector<std::string>& cameras, rosbag::Bag* out)
      : opt_(o),
        det_(params, ros::package::getPath("drill_pipe_pose") + "/models/detector/pipe_yolo.onnx"),
        out_(out) {
    for (const std::string& cam : cameras) {
      const std::string topics[4] = {
          "/" + conventions::colorImageTopic(cam), "/" + conventions::colorInfoTopic(cam),
          "/" + conventions::depthImageTopic(cam), "/" + conventions::depthInfoTopic(cam)};
      for (int i = 0; i < 4; ++i) route_[topics[i]] = {cam, i};
      // The IR amplitude (when recorded): kept by stamp and sent along as the node does.
      if (!params.amplitude_topic.empty())
        route_["/" + cam + "/" + params.amplitude_topic] = {cam, kAmplitudeInput};
      colour_topics_.push_back(topics[0]);
      auto& sync = syncs_[cam];
      sync = makeDetectorSync(params.queue_size, params.sync_slop);
      auto& handler = handlers_[cam];
      handler = std::make_unique<Handler>(Handler{this, cam});
      sync->registerCallback(&Handler::onSet, handler.get());
    }
  }

  /// TF first: the node has /tf_static (latched) before its first frame.
  void readTf(const rosbag::Bag& in) {
    for (const rosbag::MessageInstance& m :
         rosbag::View(in, rosbag::TopicQuery(std::vector<std::string>{"/tf_static", "/tf"})))
      if (auto tf = m.instantiate<tf2_msgs::TFMessage>())
        for (const auto& t : tf->transforms) det_.addTf(t, m.getTopic() == "/tf_static");
  }

  /// Every message of `in` in time order: camera topics into their synchroniser, TF and ground
  /// truth copied, anything else left out.
  void run(const rosbag::Bag& in) {
    total_ = rosbag::View(in, rosbag::TopicQuery(colour_topics_)).size();
    std::cerr << "detect_bag: " << syncs_.size() << " camera(s), " << total_
              << " colour frames, model " << det_.detector().config().model << ", depth "
              << (det_.params().crop_depth ? "cropped to the boxes" : "full") << ": " << opt_.in
              << " -> " << opt_.out << "\n";
    wall0_ = std::chrono::steady_clock::now();
    bool replaced_warned = false;
    for (const rosbag::MessageInstance& m : rosbag::View(in)) {
      const std::string& topic = m.getTopic();
      if (isPassThrough(topic)) {
        out_->write(topic, m.getTime(), m, m.getConnectionHeader());  // latching kept
        continue;
      }
      const auto r = route_.find(topic);
      if (r == route_.end()) {
        if (!replaced_warned && m.getDataType() == "drill_pipe_pose/SensorFrame") {
          std::cerr << "detect_bag: the bag's own SensorFrames (" << topic
                    << ", ...) are left out: the output has the detector's\n";
          replaced_warned = true;
        }
        continue;
      }
      if (r->second.second == kAmplitudeInput) {
        auto& kept = amplitudes_[r->second.first];
        kept.push_back(m.instantiate<Image>());
        if (kept.size() > kAmplitudeKept) kept.pop_front();
        continue;
      }
      DetectorSync& sync = *syncs_[r->second.first];
      switch (r->second.second) {
        case 0:
          sync.add<0>(m.instantiate<Image>());
          if (++done_ % 30 == 0 && !opt_.quiet) showProgress();
          break;
        case 1: sync.add<1>(m.instantiate<CameraInfo>()); break;
        case 2: sync.add<2>(m.instantiate<Image>()); break;
        default: sync.add<3>(m.instantiate<CameraInfo>()); break;
      }
    }
    if (!opt_.quiet) {
      showProgress();
      std::fprintf(stderr, "\n");
    }
  }

  /// The summary line on stdout (and the cameras whose depth went out full on stderr).
  void report() const {
    for (const std::string& cam : det_.camerasWithoutTf())
      std::cerr << "detect_bag: camera " << cam << ": the bag's TF has no colour <- depth "
                << "transform: its depth went out full (as the node sends it)\n";
    const size_t unpaired = done_ - written_ - skipped_ - bad_;
    std::printf(
        "detect_bag: wrote %zu SensorFrames of %zu colour frames (%zu skipped by max_rate, %zu "
        "dropped as bad input, %zu without a depth frame within sync_slop or still queued at the "
        "bag's end): %zu box_end and %zu pin_end boxes; detector %.1f ms per frame, %.1f s in "
        "all\n",
        written_, done_, skipped_, bad_, unpaired, det_.boxes(EndLabel::kBoxEnd),
        det_.boxes(EndLabel::kPinEnd), det_.frames() ? det_.detectorMs() / det_.frames() : 0.0,
        wallSeconds());
  }

  size_t written() const { return written_; }

 private:
  /// One camera's synchroniser callback.
  struct Handler {
    BagDetector* self;
    std::string cam;
    void onSet(const ImageConstPtr& color, const CameraInfoConstPtr& ci,
               const ImageConstPtr& depth, const CameraInfoConstPtr& di) {
      self->onFrames(cam, color, *ci, depth, *di);
    }
  };

  void onFrames(const std::string& cam, const ImageConstPtr& color, const CameraInfo& ci,
                const ImageConstPtr& depth, const CameraInfo& di) {
    std::optional<SensorFrameData> f;
    try {
      f = det_.process(cam, color, ci, depth, di, "/", amplitudeFor(cam, depth));
    } catch (const InputError& e) {  // the node drops such a frame and logs it
      if (++bad_ <= 5)
        std::cerr << "\ndetect_bag: camera " << cam << ", frame stamped " << color->header.stamp
                  << ": " << e.what() << " (frame dropped)\n";
      return;
    }
    if (!f) {
      ++skipped_;
      return;
    }
    out_->write("/" + conventions::sensorFrameTopic(cam), color->header.stamp, toMsg(*f));
    ++written_;
  }

  /// The kept amplitude image of `cam` stamped as `depth` (within 1 ms), or null.
  ImageConstPtr amplitudeFor(const std::string& cam, const ImageConstPtr& depth) const {
    const auto it = amplitudes_.find(cam);
    if (it == amplitudes_.end()) return nullptr;
    for (auto a = it->second.rbegin(); a != it->second.rend(); ++a)
      if (*a && std::abs(((*a)->header.stamp - depth->header.stamp).toSec()) <= 1e-3) return *a;
    return nullptr;
  }

  double wallSeconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
  }
  void showProgress() const {
    progress(done_, total_, wallSeconds(), det_.detectorMs(), det_.frames());
  }

  const Options& opt_;
  OfflineDetector det_;
  rosbag::Bag* out_;
  std::map<std::string, std::unique_ptr<Handler>> handlers_;
  std::map<std::string, std::unique_ptr<DetectorSync>> syncs_;
  std::map<std::string, std::pair<std::string, int>> route_;  ///< topic -> (camera, sync input)
  std::vector<std::string> colour_topics_;
  static constexpr int kAmplitudeInput = 4;      ///< route_'s input index of the IR topic
  static constexpr size_t kAmplitudeKept = 16;  ///< per camera, to match by stamp
  std::map<std::string, std::deque<ImageConstPtr>> amplitudes_;
  size_t total_ = 0, done_ = 0, written_ = 0, skipped_ = 0, bad_ = 0;
  std::chrono::steady_clock::time_point wall0_;
};

}  // namespace

int main(int argc, char** argv) {
  const Options opt = parseArgs(argc, argv);
  ros::Time::init();  // message_filters reads the wall clock (no ROS master is used)
  try {
    const PipeDetectorNodeConfig params = makeParams(opt);
    rosbag::Bag in;
    try {
      in.open(opt.in, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
      fail("cannot open bag '", opt.in, "': ", e.what());
    }
    const std::vector<std::string> cameras = bagCameras(in, opt);
    rosbag::Bag out;
    BagDetector run(opt, params, cameras, &out);  // loads the model before the output is made
    run.readTf(in);
    try {
      out.open(opt.out, rosbag::bagmode::Write);
    } catch (const rosbag::BagException& e) {
      fail("cannot write bag '", opt.out, "': ", e.what());
    }
    out.setCompression(rosbag::compression::LZ4);
    run.run(in);
    out.close();
    run.report();
    if (run.written() == 0) fail("no SensorFrame written (see above)");
  } catch (const InputError& e) {
    std::cerr << "\ndetect_bag: " << e.what() << "\n";
    return 1;
  } catch (const cv::Exception& e) {
    std::cerr << "\ndetect_bag: OpenCV: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
