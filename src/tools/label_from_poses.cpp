// label_from_poses: the detector's training data from the estimator's 3D poses (assisted
// annotation): every camera's colour image labelled by projecting the tool-joint model at each
// end's pose, checked against the depth images (core/detector/pose_labels.hpp), written as a
// YOLO / VOC dataset (core/detector/dataset_writer.hpp) with a review sheet sorted by doubt.
//
//   rosrun drill_pipe_pose label_from_poses --recording REC.bag --out DIR [--poses POSES.bag]
//       [--corrections corrections.yaml] [--rejected rejected.yaml] [--name PREFIX]
//       [--cameras cam1,cam2] [--split train] [--format both|yolo|voc] [--pipe-type NAME]
//       [--max-position-sigma 0.03] [--max-axis-sigma 90] [--min-pose-cameras 2]
//       [--min-agreeing-cameras 2] [--agree-fraction 0.6] [--own-agree-fraction 0.2]
//       [--review-doubt 0.1] [--score-against TRUTH.bag] [--quiet]
//
// REC.bag: the rig's camera topics as kinect2_bridge publishes them (per camera
// <cam>/qhd/image_color_rect, <cam>/qhd/camera_info, <cam>/sd/image_depth_rect,
// <cam>/sd/camera_info; docs/conventions.md) and /tf_static; `simulate_bag --color
// --no-detection` writes the same. Each colour image is paired with its camera's depth image of
// the same stamp (within 20 ms).
// POSES.bag (default: REC.bag): the estimator's /drill_pipe_pose/pipe_ends (PipeEnds), as
// `rosbag record` takes them from the node or `bench_estimator --poses-bag` writes them. A
// PipeEnd's pose is taken at the time of its data (stamp - age) and interpolated to each image.
// Poses carry their covariance and cameras, which the gates need (hence a bag, not
// bench_estimator's cycles CSV).
// corrections.yaml: a person's poses (review_sheet.hpp, loadCorrections); each replaces the
// estimator's pose of its end in every camera's image nearest its stamp (within 50 ms).
// rejected.yaml: ids ticked on the review sheet; their images are left out.
// Output: DIR/yolo, DIR/voc (render_dataset's layout; scripts/train_detector.py --finetune
// DIR/yolo), DIR/review/index.html and DIR/review/crops/.
// --score-against TRUTH.bag: the simulator's true boxes of the same captures (`simulate_bag
// --true-boxes`, SensorFrames; never read for labelling) to score the labels: median IoU, the
// wrong-label rate (a box whose best true box of its label overlaps less than IoU 0.5: on the
// wrong end or on nothing), missed true boxes in the kept images, and where the wrong labels rank
// on the review sheet. One machine-readable LABELS line; every label's IoU in DIR/score.csv.
// Exit status 0; 1 on bad input (the message names the bag, topic, camera or file); 2 on a bad
// command line.
#include <drill_pipe_pose/PipeEnds.h>
#include <drill_pipe_pose/SensorFrame.h>
#include <ros/package.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "cli.hpp"
#include "drill_pipe_pose/core/detector/dataset_writer.hpp"
#include "drill_pipe_pose/core/detector/pose_labels.hpp"
#include "drill_pipe_pose/core/detector/review_sheet.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/tf_source.hpp"

using namespace drill_pipe_pose;
namespace fs = std::filesystem;

namespace {

struct Options {
  std::string recording, poses, out, corrections, rejected, name, cameras, pipe_type;
  std::string split = "train", format = "both", score_against;
  std::string poses_topic = std::string("/drill_pipe_pose/") + conventions::kPipeEndsTopic;
  double review_doubt = kDefaultReviewDoubt;
  // An end is in the recording when a pose that passes the gate is reported in at least this
  // share of the cycles (see readPoses). Chosen between the phantom of seed 111 (7 of 121 cycles,
  // 6 %) and the real ends: 99-120 of 120 on the static scenes of seed 110; the pin end of the
  // moving new-look recording (scripts/bench_new_look, seed 180, the shipped detector) 339 of 900
  // (38 %) with 2 s per pose and 514 of 1800 (29 %) with the scene's 4 s. The former "half of the
  // cycles" called it a phantom: its images were kept with the box end labelled and the visible
  // pin end not, teaching the detector that pin ends are background.
  double min_end_share = 0.2;
  bool quiet = false;
  LabelParams params;
};

Options parseArgs(int argc, char** argv) {
  Options o;
  CLI::App app{"Labels every camera's colour image of a recording from the estimator's 3D poses "
               "(projected tool-joint model, checked against depth) into a YOLO / VOC dataset "
               "with a review sheet.",
               "label_from_poses"};
  tools::configureApp(app);
  app.add_option("--recording", o.recording,
                 "bag of the cameras' colour, depth and camera_info topics and /tf_static")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--out", o.out, "dataset folder to write (yolo/, voc/, review/)")->required();
  app.add_option("--poses", o.poses,
                 "bag with the estimator's pipe_ends (default: the recording)")
      ->check(CLI::ExistingFile);
  app.add_option("--poses-topic", o.poses_topic, "topic of the PipeEnds messages")
      ->capture_default_str();
  app.add_option("--corrections", o.corrections,
                 "a person's corrected poses (YAML): each relabels every camera at its stamp")
      ->check(CLI::ExistingFile);
  app.add_option("--rejected", o.rejected,
                 "rejected label ids (YAML, saved by the review sheet): their images are left out")
      ->check(CLI::ExistingFile);
  app.add_option("--name", o.name, "prefix of the image names (default: the recording's name)");
  app.add_option("--cameras", o.cameras, "only these cameras, comma-separated (default: all)")
      ->option_text("cam1,cam2");
  app.add_option("--split", o.split, "dataset split the images go to")->capture_default_str();
  app.add_option("--format", o.format, "datasets to write")
      ->capture_default_str()
      ->check(CLI::IsMember({"both", "yolo", "voc"}));
  app.add_option("--pipe-type", o.pipe_type,
                 "the tool joints' pipe catalogue entry (config/pipe_catalog.yaml; default: the "
                 "5in_NC50_6.625od geometry)");
  app.add_option("--max-position-sigma", o.params.max_position_sigma,
                 "[m] largest position standard deviation of a pose that labels")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-axis-sigma", o.params.max_axis_sigma_deg,
                 "[deg] largest axis standard deviation of a pose that labels")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--min-pose-cameras", o.params.min_pose_cameras,
                 "cameras that must have contributed points to a pose")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_option("--min-agreeing-cameras", o.params.min_agreeing_cameras,
                 "cameras whose depth must confirm a pose at the image's moment")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_option("--agree-fraction", o.params.agree_fraction,
                 "share of a camera's measured model points that must agree with its depth for "
                 "it to confirm a pose (and for its image to be labelled)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--own-agree-fraction", o.params.own_agree_fraction,
                 "share of the image's own camera's measured model points that must agree with "
                 "its depth for the image to be labelled")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--review-doubt", o.review_doubt,
                 "labels at or above this doubt are the ones the review sheet asks a person to "
                 "look at")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--min-end-share", o.min_end_share,
                 "an end is in the recording (every image must then have its pose or is left "
                 "out) when a pose that passes the gate is reported in at least this share of "
                 "the cycles; below it, a phantom of swapped boxes")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--score-against", o.score_against,
                 "bag of the true boxes of the same captures (simulate_bag --true-boxes): score "
                 "the labels (never used for labelling)")
      ->check(CLI::ExistingFile);
  app.add_flag("--quiet", o.quiet, "no progress lines");
  tools::parseOrExit(app, argc, argv);
  if (o.poses.empty()) o.poses = o.recording;
  if (o.name.empty()) o.name = fs::path(o.recording).stem().string();
  return o;
}

std::set<std::string> splitList(const std::string& s) {
  std::set<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.insert(item);
  return out;
}

void openBag(const std::string& path, rosbag::Bag* bag) {
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    fail("cannot open bag '", path, "': ", e.what());
  }
}

/// The camera name of a kinect2_bridge topic /<cam>/<suffix>, or "".
std::string cameraOf(const std::string& topic, const std::string& suffix) {
  const std::string t = topic.front() == '/' ? topic.substr(1) : topic;
  if (t.size() <= suffix.size() + 1 || t.compare(t.size() - suffix.size(), suffix.size(), suffix))
    return "";
  return t.substr(0, t.size() - suffix.size() - 1);
}

/// The estimator's poses (PipeEnd: pose at stamp - age, covariance, cameras) per end; which ends
/// are in the recording (see readPoses); the world frame.
struct Poses {
  std::array<PoseTrack, kNumEnds> tracks;
  std::array<bool, kNumEnds> seen{{false, false}};
  std::array<size_t, kNumEnds> passing{{0, 0}};  ///< cycles with a pose that passes the gate
  std::string world_frame;
  size_t messages = 0;
};

Poses readPoses(const Options& o) {
  rosbag::Bag bag;
  openBag(o.poses, &bag);
  Poses p;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(o.poses_topic))) {
    const auto msg = m.instantiate<PipeEnds>();
    if (!msg) fail("bag '", o.poses, "': topic ", o.poses_topic, " is not drill_pipe_pose/PipeEnds");
    ++p.messages;
    p.world_frame = msg->header.frame_id;
    for (const PipeEnd& e : msg->ends) {
      if (!e.valid) continue;
      PoseSample s;
      if (e.label == "box_end") s.label = EndLabel::kBoxEnd;
      else if (e.label == "pin_end") s.label = EndLabel::kPinEnd;
      else fail("bag '", o.poses, "', ", o.poses_topic, ": unknown end label '", e.label, "'");
      s.stamp_ns = toNs(msg->header.stamp) - static_cast<int64_t>(e.age.toNSec());
      tf2::fromMsg(e.pose.pose, s.T_world_end);
      for (int i = 0; i < 36; ++i) s.covariance(i / 6, i % 6) = e.pose.covariance[i];
      s.cameras = static_cast<int>(e.cameras.size());
      p.tracks[static_cast<int>(s.label)].add(s);
      if (gatePose(s, o.params).ok) ++p.passing[static_cast<int>(s.label)];
    }
  }
  if (!p.messages)
    fail("bag '", o.poses, "' has no PipeEnds on ", o.poses_topic,
         " (record the estimator's pipe_ends, or run bench_estimator --poses-bag)");
  // An end every image must decide on is one the estimator reports with a pose that passes the
  // gate in at least --min-end-share of its cycles. A phantom end from the detector's swapped
  // boxes is reported in a few cycles only: thesis_angled has no pin end; on seed 110 its phantom
  // pin end never passes the gate, on held-out seed 111 it passes in 7 of 121 cycles and made
  // every image wait for a pin-end pose (a rule found on a held-out seed; docs/results.md says
  // so). Real ends pass in 99-120 of 120 cycles on seed 110, also with 30 % of the poses
  // perturbed (scripts/bench_labels --seeds 110 [--perturb 0.3]), and in 29-38 % of the cycles
  // where the joints move from pose to pose (Options::min_end_share).
  for (int e = 0; e < kNumEnds; ++e)
    p.seen[e] = static_cast<double>(p.passing[e]) >= o.min_end_share * p.messages;
  return p;
}

/// The recording's images: per view (one depth image of one camera) its camera and stamp.
struct Recording {
  std::map<std::string, std::map<int64_t, size_t>> index;  ///< camera -> stamp -> view
};

void readTf(rosbag::Bag& bag, TfTransforms* tf) {
  for (const rosbag::MessageInstance& m :
       rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{"/tf_static", "/tf"})))
    if (auto msg = m.instantiate<tf2_msgs::TFMessage>())
      for (const auto& t : msg->transforms) tf->add(t, m.getTopic() == "/tf_static");
}

/// The recording's topics with this suffix (/<cam>/<suffix>), for the cameras asked for.
std::vector<std::string> cameraTopics(rosbag::Bag& bag, const std::vector<std::string>& suffixes,
                                      const std::set<std::string>& only) {
  std::vector<std::string> topics;
  rosbag::View all(bag);
  for (const rosbag::ConnectionInfo* c : all.getConnections())
    for (const std::string& suffix : suffixes) {
      const std::string cam = cameraOf(c->topic, suffix);
      if (!cam.empty() && (only.empty() || only.count(cam)) &&
          std::find(topics.begin(), topics.end(), c->topic) == topics.end())
        topics.push_back(c->topic);
    }
  return topics;
}

/// A person's corrected poses, each moved to every camera's image nearest its stamp (within
/// correction_window): (camera, stamp, end) -> pose.
using Corrections = std::map<std::tuple<std::string, int64_t, int>, PoseSample>;

Corrections assignCorrections(const std::vector<PoseSample>& cs,
                              const std::map<std::string, std::set<int64_t>>& stamps,
                              const LabelParams& params) {
  Corrections out;
  const int64_t window = static_cast<int64_t>(params.correction_window * 1e9);
  for (const PoseSample& c : cs)
    for (const auto& [cam, set] : stamps) {
      auto it = set.lower_bound(c.stamp_ns);
      std::optional<int64_t> best;
      if (it != set.end()) best = *it;
      if (it != set.begin() && (!best || c.stamp_ns - *std::prev(it) < *best - c.stamp_ns))
        best = *std::prev(it);
      if (best && std::abs(*best - c.stamp_ns) <= window) {
        PoseSample p = c;
        p.stamp_ns = *best;
        out[{cam, *best, static_cast<int>(c.label)}] = p;
      }
    }
  return out;
}

/// The camera's colour and depth models and placement for a depth image (TF at its stamp).
LabelView makeView(const std::string& cam, const sensor_msgs::ImageConstPtr& depth,
                   const sensor_msgs::CameraInfo& depth_info,
                   const sensor_msgs::CameraInfo& color_info, const std::string& world,
                   TfTransforms& tf) {
  LabelView v;
  v.camera = cam;
  v.stamp_ns = toNs(depth->header.stamp);
  v.color = PinholeCamera::fromCameraInfo(fromMsg(color_info), cam + " qhd/camera_info");
  v.depth = PinholeCamera::fromCameraInfo(fromMsg(depth_info), cam + " sd/camera_info");
  v.depth_image = depthFromMsg(depth, cam + " sd/image_depth_rect");
  if (v.depth_image.width != v.depth.imageWidth() || v.depth_image.height != v.depth.imageHeight())
    fail("camera ", cam, ": sd/image_depth_rect is ", v.depth_image.width, "x",
         v.depth_image.height, " but sd/camera_info says ", v.depth.imageWidth(), "x",
         v.depth.imageHeight());
  const std::string color_frame = color_info.header.frame_id.empty()
                                      ? conventions::colorOpticalFrame(cam)
                                      : color_info.header.frame_id;
  const std::string depth_frame = depth->header.frame_id.empty()
                                      ? conventions::depthOpticalFrame(cam)
                                      : depth->header.frame_id;
  try {
    v.T_world_color = tf.lookup(world, color_frame, v.stamp_ns);
    v.T_world_depth = tf.lookup(world, depth_frame, v.stamp_ns);
  } catch (const tf2::TransformException& e) {
    fail("camera ", cam, ": no transform ", world, " <- ", color_frame, " / ", depth_frame,
         " in the recording's TF: ", e.what());
  }
  return v;
}

/// Every camera's depth-image stamps (from sd/camera_info, which comes with each depth image).
std::map<std::string, std::set<int64_t>> depthStamps(rosbag::Bag& bag,
                                                     const std::set<std::string>& only) {
  std::map<std::string, std::set<int64_t>> out;
  for (const rosbag::MessageInstance& m :
       rosbag::View(bag, rosbag::TopicQuery(cameraTopics(bag, {"sd/camera_info"}, only))))
    if (auto i = m.instantiate<sensor_msgs::CameraInfo>())
      out[cameraOf(m.getTopic(), "sd/camera_info")].insert(toNs(i->header.stamp));
  return out;
}

/// Pass 1: every depth image with its camera models and TF; every end projected at its pose
/// (a person's correction, else the estimator's interpolated to the image's stamp).
void projectRecording(const Options& o, const Poses& poses,
                      const std::array<LabelModel, kNumEnds>& models,
                      const Corrections& corrections, Recording* rec, LabelInputs* in) {
  rosbag::Bag bag;
  openBag(o.recording, &bag);
  TfTransforms tf;
  readTf(bag, &tf);
  const std::vector<std::string> topics = cameraTopics(
      bag, {"qhd/camera_info", "sd/camera_info", "sd/image_depth_rect"}, splitList(o.cameras));
  if (topics.empty())
    fail("bag '", o.recording, "' has no <cam>/sd/image_depth_rect or camera_info topics");
  std::map<std::string, sensor_msgs::CameraInfo> color_info, depth_info;
  size_t depth_images = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topics))) {
    const std::string& topic = m.getTopic();
    std::string cam;
    if (!(cam = cameraOf(topic, "qhd/camera_info")).empty()) {
      if (auto i = m.instantiate<sensor_msgs::CameraInfo>()) color_info[cam] = *i;
      continue;
    }
    if (!(cam = cameraOf(topic, "sd/camera_info")).empty()) {
      if (auto i = m.instantiate<sensor_msgs::CameraInfo>()) depth_info[cam] = *i;
      continue;
    }
    cam = cameraOf(topic, "sd/image_depth_rect");
    const auto img = m.instantiate<sensor_msgs::Image>();
    if (!img) fail("bag '", o.recording, "': ", topic, " is not sensor_msgs/Image");
    if (!color_info.count(cam) || !depth_info.count(cam)) continue;  // infos not seen yet
    const LabelView view =
        makeView(cam, img, depth_info[cam], color_info[cam], poses.world_frame, tf);
    const size_t v = in->cameras.size();
    rec->index[cam][view.stamp_ns] = v;
    in->cameras.push_back(cam);
    in->stamps_ns.push_back(view.stamp_ns);
    in->poses.emplace_back();
    in->projections.emplace_back();
    for (int e = 0; e < kNumEnds; ++e) {
      const auto c = corrections.find({cam, view.stamp_ns, e});
      in->poses[v][e] = c != corrections.end()
                            ? std::optional<PoseSample>(c->second)
                            : poses.tracks[e].at(view.stamp_ns, o.params.max_pose_gap);
      if (in->poses[v][e]) {
        EndInView& p = in->projections[v][e];
        p = projectEnd(models[e], in->poses[v][e]->T_world_end, view, o.params);
        if (!in->poses[v][e]->corrected) p.spread_px = poseSpreadPx(models[e], *in->poses[v][e], view);
      }
    }
    if (++depth_images % 50 == 0 && !o.quiet)
      std::fprintf(stderr, "\rlabel_from_poses: %zu depth images", depth_images);
  }
  if (!o.quiet) std::fprintf(stderr, "\rlabel_from_poses: %zu depth images\n", depth_images);
  if (!depth_images)
    fail("bag '", o.recording, "': no depth image with both camera_info topics of its camera");
}

/// The colour image of a message as BGR (bgr8, rgb8 or mono8); throws naming the camera.
cv::Mat colorImage(const sensor_msgs::Image& msg, const std::string& cam) {
  const int type = msg.encoding == "mono8" ? CV_8UC1 : CV_8UC3;
  if (msg.encoding != "bgr8" && msg.encoding != "rgb8" && msg.encoding != "mono8")
    fail("camera ", cam, ": qhd/image_color_rect has encoding '", msg.encoding,
         "' (expected bgr8, rgb8 or mono8)");
  const size_t row = msg.width * (type == CV_8UC1 ? 1 : 3);
  if (msg.step < row || msg.data.size() < static_cast<size_t>(msg.step) * msg.height)
    fail("camera ", cam, ": qhd/image_color_rect is ", msg.width, "x", msg.height, " with step ",
         msg.step, " but holds ", msg.data.size(), " bytes");
  const cv::Mat wrap(static_cast<int>(msg.height), static_cast<int>(msg.width), type,
                     const_cast<uint8_t*>(msg.data.data()), msg.step);
  cv::Mat bgr;
  if (msg.encoding == "bgr8") bgr = wrap.clone();
  else if (msg.encoding == "rgb8") cv::cvtColor(wrap, bgr, cv::COLOR_RGB2BGR);
  else cv::cvtColor(wrap, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

/// The view of a colour image: its camera's depth image of the same stamp (within 20 ms).
std::optional<size_t> viewOf(const Recording& rec, const std::string& cam, int64_t stamp) {
  const auto c = rec.index.find(cam);
  if (c == rec.index.end()) return std::nullopt;
  const int64_t tol = 20000000;
  auto it = c->second.lower_bound(stamp - tol);
  if (it == c->second.end() || it->first > stamp + tol) return std::nullopt;
  auto best = it;
  for (; it != c->second.end() && it->first <= stamp + tol; ++it)
    if (std::abs(it->first - stamp) < std::abs(best->first - stamp)) best = it;
  return best->second;
}

/// What pass 2 wrote.
struct Written {
  std::vector<ReviewEntry> review;
  std::map<size_t, std::string> images;  ///< view -> dataset image name
  size_t rejected_images = 0;
};

/// Pass 2: every colour image whose view is kept goes into the dataset with its labels, each
/// label's crop into the review folder.
Written writeDataset(const Options& o, const Recording& rec, const std::vector<ImageLabels>& labels,
                     const std::set<std::string>& rejected) {
  rosbag::Bag bag;
  openBag(o.recording, &bag);
  DatasetWriterOptions wo;
  wo.out = o.out;
  wo.split = o.split;
  wo.format = o.format;
  wo.source = "drill_pipe_pose label_from_poses";
  wo.tool = "label_from_poses";
  DatasetWriter writer(wo);
  const fs::path crops = fs::path(o.out) / "review" / "crops";
  std::error_code ec;
  fs::create_directories(crops, ec);
  if (ec) fail("cannot create the folder ", crops.string(), ": ", ec.message());
  Written w;
  for (const rosbag::MessageInstance& m : rosbag::View(
           bag, rosbag::TopicQuery(cameraTopics(bag, {"qhd/image_color_rect"}, splitList(o.cameras))))) {
    const std::string cam = cameraOf(m.getTopic(), "qhd/image_color_rect");
    const auto msg = m.instantiate<sensor_msgs::Image>();
    if (!msg) fail("bag '", o.recording, "': ", m.getTopic(), " is not sensor_msgs/Image");
    const auto v = viewOf(rec, cam, toNs(msg->header.stamp));
    if (!v || !labels[*v].keep) continue;
    const ImageLabels& il = labels[*v];
    if (std::any_of(il.labels.begin(), il.labels.end(),
                    [&](const LabelItem& l) { return rejected.count(l.id); })) {
      ++w.rejected_images;
      continue;
    }
    const cv::Mat bgr = colorImage(*msg, cam);
    const std::string name = o.name + "_" + cam + "_" + std::to_string(il.stamp_ns);
    std::vector<DetectionBox> boxes;
    for (const LabelItem& l : il.labels) boxes.push_back(l.box);
    writer.write(name, bgr, boxes);
    w.images[*v] = name;
    for (const LabelItem& l : il.labels) {
      ReviewEntry r;
      r.item = l;
      r.image = name;
      r.crop = "crops/" + l.id + ".jpg";
      const auto& pose = il.poses[static_cast<int>(l.box.label)];
      r.T_world_end = pose->T_world_end;
      r.pose_stamp_ns = il.stamp_ns;
      const fs::path cp = fs::path(o.out) / "review" / r.crop;
      if (!cv::imwrite(cp.string(), reviewCrop(bgr, l.box), {cv::IMWRITE_JPEG_QUALITY, 90}))
        fail("cannot write ", cp.string());
      w.review.push_back(r);
    }
  }
  return w;
}

double iou(const DetectionBox& a, const DetectionBox& b) {
  const double iw = std::max(0.0, double(std::min(a.x_max, b.x_max) - std::max(a.x_min, b.x_min)));
  const double ih = std::max(0.0, double(std::min(a.y_max, b.y_max) - std::max(a.y_min, b.y_min)));
  const double inter = iw * ih;
  const double u = double(a.x_max - a.x_min) * (a.y_max - a.y_min) +
                   double(b.x_max - b.x_min) * (b.y_max - b.y_min) - inter;
  return u > 0 ? inter / u : 0.0;
}

/// --score-against: the labels of the written images against the simulator's true boxes.
void score(const Options& o, const std::vector<ImageLabels>& labels, const Written& w,
           size_t to_review) {
  rosbag::Bag bag;
  openBag(o.score_against, &bag);
  std::map<std::pair<std::string, int64_t>, std::vector<DetectionBox>> truth;
  for (const rosbag::MessageInstance& m : rosbag::View(bag))
    if (auto sf = sensorFrameOf(m)) {
      auto& bs = truth[{sf->camera, toNs(sf->header.stamp)}];
      for (const PipeBox& b : sf->boxes) bs.push_back(fromMsg(b, sf->camera));
    }
  if (truth.empty()) fail("bag '", o.score_against, "' has no SensorFrames with true boxes");
  std::vector<double> ious;
  std::vector<std::string> wrong_ids;
  const std::string csv_path = (fs::path(o.out) / "score.csv").string();
  std::ofstream csv(csv_path);
  if (!csv) fail("cannot write '", csv_path, "'");
  csv << "id,end,iou,doubt,disagree,unconfirmed,spread,spread_px,position_sigma_mm,"
         "axis_sigma_deg,visible_fraction,agreeing_cameras,measured_cameras,in_view_cameras\n";
  size_t missed = 0, true_boxes = 0, no_truth = 0;
  for (const auto& [v, name] : w.images) {
    const ImageLabels& il = labels[v];
    const auto t = truth.find({il.camera, il.stamp_ns});
    if (t == truth.end()) {
      ++no_truth;
      continue;
    }
    for (const LabelItem& l : il.labels) {
      double best = 0.0;
      for (const DetectionBox& b : t->second)
        if (b.label == l.box.label) best = std::max(best, iou(b, l.box));
      ious.push_back(best);
      if (best < 0.5) wrong_ids.push_back(l.id);
      const DoubtParts d = doubtParts(l);
      csv << l.id << "," << labelName(l.box.label) << "," << best << "," << l.doubt << ","
          << d.disagree << "," << d.unconfirmed << "," << d.spread << "," << l.spread_px << ","
          << l.position_sigma * 1e3 << "," << l.axis_sigma_deg << "," << l.visible_fraction << ","
          << l.agreeing_cameras << "," << l.measured_cameras << "," << l.in_view_cameras << "\n";
    }
    for (const DetectionBox& b : t->second) {
      ++true_boxes;
      const bool found = std::any_of(il.labels.begin(), il.labels.end(), [&](const LabelItem& l) {
        return l.box.label == b.label && iou(b, l.box) >= 0.5;
      });
      if (!found) ++missed;
    }
  }
  // Where the wrong labels rank on the review sheet (most doubtful first).
  std::vector<std::pair<double, std::string>> order;
  for (const ReviewEntry& r : w.review) order.emplace_back(-r.item.doubt, r.item.id);
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  size_t wrong_in_review = 0, worst_rank = 0;
  for (size_t k = 0; k < order.size(); ++k)
    if (std::find(wrong_ids.begin(), wrong_ids.end(), order[k].second) != wrong_ids.end()) {
      worst_rank = k + 1;
      if (k < to_review) ++wrong_in_review;
    }
  std::sort(ious.begin(), ious.end());
  const double median = ious.empty() ? 0.0 : ious[ious.size() / 2];
  const double rate = ious.empty() ? 0.0 : double(wrong_ids.size()) / ious.size();
  std::cout << std::fixed << std::setprecision(4) << "score against " << o.score_against << ": "
            << ious.size() << " labels in " << w.images.size() << " images, median IoU " << median
            << ", wrong " << wrong_ids.size() << " (" << 100 * rate << " %), missed " << missed
            << " of " << true_boxes << " true boxes in the kept images; " << wrong_in_review
            << " wrong labels among the " << to_review << " to review, the last wrong at rank "
            << worst_rank << "\n";
  for (const std::string& id : wrong_ids) std::cout << "wrong label: " << id << "\n";
  if (no_truth) std::cout << "no true boxes for " << no_truth << " images\n";
  std::cout << "LABELS label=" << o.name << " labels=" << ious.size()
            << " images=" << w.images.size() << " median_iou=" << median
            << " wrong=" << wrong_ids.size() << " wrong_rate=" << rate << " missed=" << missed
            << " true_boxes=" << true_boxes << " to_review=" << to_review
            << " wrong_in_review=" << wrong_in_review << " last_wrong_rank=" << worst_rank << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseArgs(argc, argv);
  try {
    ToolJointDimensions dims;
    if (!o.pipe_type.empty())
      dims = loadPipeCatalog(pipeCatalogPath(ros::package::getPath("drill_pipe_pose")))
                 .at(o.pipe_type)
                 .dims;
    const std::array<LabelModel, kNumEnds> models = {
        makeLabelModel(EndLabel::kBoxEnd, dims, o.params.point_spacing),
        makeLabelModel(EndLabel::kPinEnd, dims, o.params.point_spacing)};
    const Poses poses = readPoses(o);
    Corrections corrections;
    if (!o.corrections.empty()) {
      rosbag::Bag bag;
      openBag(o.recording, &bag);
      corrections = assignCorrections(loadCorrections(o.corrections),
                                      depthStamps(bag, splitList(o.cameras)), o.params);
    }
    const std::set<std::string> rejected =
        o.rejected.empty() ? std::set<std::string>() : loadRejected(o.rejected);
    Recording rec;
    LabelInputs in;
    in.expected = poses.seen;
    projectRecording(o, poses, models, corrections, &rec, &in);
    const std::vector<ImageLabels> labels = labelImages(in, o.params);
    std::map<std::string, size_t> why;
    for (const ImageLabels& l : labels)
      if (!l.keep) {
        // Count reasons without their numbers.
        std::string k = l.why.substr(0, l.why.find_first_of("0123456789"));
        ++why[k];
      }
    const Written w = writeDataset(o, rec, labels, rejected);
    const size_t to_review =
        writeReviewSheet((fs::path(o.out) / "review").string(), w.review, o.review_doubt,
                         "label_from_poses: " + o.name);
    size_t n_labels = 0;
    std::array<size_t, kNumEnds> per_end{{0, 0}};
    for (const ReviewEntry& r : w.review) {
      ++n_labels;
      ++per_end[static_cast<int>(r.item.box.label)];
    }
    std::printf("label_from_poses: %zu images of %zu kept (%zu box_end, %zu pin_end labels), "
                "%zu left out by a person's rejection; %zu corrected poses applied\n",
                w.images.size(), labels.size(), per_end[0], per_end[1], w.rejected_images,
                corrections.size());
    for (int e = 0; e < kNumEnds; ++e)
      std::printf("  %s: a pose that passes the gate in %zu of %zu cycles: %s\n",
                  labelName(static_cast<EndLabel>(e)), poses.passing[e], poses.messages,
                  poses.seen[e] ? "in the recording" : "not in the recording (a phantom)");
    for (const auto& [k, n] : why) std::printf("  left out %zux: %s\n", n, k.c_str());
    std::printf("review sheet %s/review/index.html: %zu labels, look at the first %zu (doubt >= "
                "%.2f)\n",
                o.out.c_str(), n_labels, to_review, o.review_doubt);
    if (!o.score_against.empty()) score(o, labels, w, to_review);
  } catch (const InputError& e) {
    std::cerr << "label_from_poses: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
