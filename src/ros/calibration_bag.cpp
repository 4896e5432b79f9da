#include "drill_pipe_pose/ros/calibration_bag.hpp"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <deque>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"

namespace drill_pipe_pose {

namespace cal = calibration;

namespace {

std::string stripSlash(const std::string& s) { return s.rfind('/', 0) == 0 ? s.substr(1) : s; }

/// The camera's image topics in the bag (with the leading slash the bag has).
struct CameraTopics {
  std::string image, image_info, depth, depth_info;
};

CameraTopics topicsOf(const std::string& cam, const std::string& image_topic) {
  const std::string ns = image_topic.find('/') == std::string::npos
                             ? std::string()
                             : image_topic.substr(0, image_topic.rfind('/') + 1);
  return {"/" + cam + "/" + image_topic, "/" + cam + "/" + ns + "camera_info",
          "/" + conventions::depthImageTopic(cam), "/" + conventions::depthInfoTopic(cam)};
}

/// Cameras with `image_topic` in the bag (all of them, or those asked for).
std::vector<std::string> findCameras(const rosbag::Bag& bag, const CalibrationBagOptions& o,
                                     const std::string& path) {
  std::set<std::string> found;
  rosbag::View all(bag);
  const std::string suffix = "/" + o.image_topic;
  for (const rosbag::ConnectionInfo* c : all.getConnections()) {
    const std::string t = stripSlash(c->topic);
    if (t.size() > suffix.size() && t.compare(t.size() - suffix.size(), suffix.size(), suffix) == 0)
      found.insert(t.substr(0, t.size() - suffix.size()));
  }
  if (o.cameras.empty()) {
    if (found.empty()) fail("bag '", path, "': no topic <cam>/", o.image_topic, " in it");
    return {found.begin(), found.end()};
  }
  for (const std::string& cam : o.cameras)
    if (!found.count(cam)) fail("bag '", path, "': camera ", cam, ": no topic /", cam, suffix);
  return o.cameras;
}

/// The cameras' setups from their CameraInfos and /tf_static.
std::vector<cal::CameraSetup> readSetups(const rosbag::Bag& bag, const std::vector<std::string>& cams,
                                         const CalibrationBagOptions& o, const std::string& path) {
  std::map<std::string, sensor_msgs::CameraInfo::ConstPtr> infos;
  std::map<std::string, Eigen::Isometry3d> tf;  // "parent child" -> T_parent_child
  std::vector<std::string> topics = {"/tf_static", "tf_static"};
  for (const std::string& c : cams) {
    const CameraTopics t = topicsOf(c, o.image_topic);
    topics.insert(topics.end(), {t.image_info, t.depth_info, stripSlash(t.image_info),
                                 stripSlash(t.depth_info)});
  }
  rosbag::View view(bag, rosbag::TopicQuery(topics));
  for (const rosbag::MessageInstance& m : view) {
    if (auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
      infos.emplace("/" + stripSlash(m.getTopic()), info);
    } else if (auto msg = m.instantiate<tf2_msgs::TFMessage>()) {
      for (const auto& t : msg->transforms)
        tf[stripSlash(t.header.frame_id) + " " + stripSlash(t.child_frame_id)] =
            tf2::transformToEigen(t.transform);
    }
  }
  std::vector<cal::CameraSetup> setups;
  for (const std::string& c : cams) {
    const CameraTopics t = topicsOf(c, o.image_topic);
    for (const std::string& topic : {t.image_info, t.depth_info})
      if (!infos.count(topic)) fail("bag '", path, "': camera ", c, ": no message on ", topic);
    cal::CameraSetup s;
    s.name = c;
    s.intrinsics = cal::intrinsicsFromCameraInfo(fromMsg(*infos[t.image_info]),
                                                 "bag '" + path + "': " + t.image_info);
    s.depth_intrinsics = cal::intrinsicsFromCameraInfo(fromMsg(*infos[t.depth_info]),
                                                       "bag '" + path + "': " + t.depth_info);
    const std::string key = conventions::colorOpticalFrame(c) + " " + conventions::depthOpticalFrame(c);
    const auto it = tf.find(key);
    if (it == tf.end())
      fail("bag '", path, "': camera ", c, ": no transform ", conventions::colorOpticalFrame(c),
           " -> ", conventions::depthOpticalFrame(c),
           " in /tf_static (the driver's colour-to-depth calibration; record /tf_static too)");
    s.T_camera_depth = it->second;
    setups.push_back(s);
  }
  return setups;
}

/// An image message as the 8-bit grey image the target is found in.
cv::Mat grayOf(const sensor_msgs::Image& m, const std::string& where) {
  int type = -1;
  if (m.encoding == "mono8") type = CV_8UC1;
  if (m.encoding == "bgr8" || m.encoding == "rgb8") type = CV_8UC3;
  if (m.encoding == "mono16") type = CV_16UC1;
  if (type < 0) fail(where, ": image encoding '", m.encoding, "' (expected mono8, bgr8 or rgb8)");
  if (m.step * m.height > m.data.size())
    fail(where, ": image data of ", m.data.size(), " bytes is smaller than step x height");
  const cv::Mat wrap(static_cast<int>(m.height), static_cast<int>(m.width), type,
                     const_cast<uint8_t*>(m.data.data()), m.step);
  if (m.encoding == "rgb8") {
    cv::Mat gray;
    cv::cvtColor(wrap, gray, cv::COLOR_RGB2GRAY);
    return gray;
  }
  return cal::toDetectionGray(wrap, where).clone();
}

/// Pairs a camera's images and depth images by stamp (within max_pair_dt), both arriving in bag
/// order; a pair is returned once, unpaired messages are dropped after a few newer ones.
class Pairer {
 public:
  using ImagePtr = sensor_msgs::Image::ConstPtr;
  explicit Pairer(double max_dt) : max_dt_(max_dt) {}
  /// Adds a message (depth or not); returns the (image, depth) pair it completes, if any.
  std::pair<ImagePtr, ImagePtr> add(const ImagePtr& msg, bool is_depth) {
    std::deque<ImagePtr>& other = is_depth ? images_ : depths_;
    for (auto it = other.begin(); it != other.end(); ++it)
      if (std::abs(((*it)->header.stamp - msg->header.stamp).toSec()) <= max_dt_) {
        const ImagePtr match = *it;
        other.erase(other.begin(), it + 1);  // older ones will not pair any more
        return is_depth ? std::make_pair(match, msg) : std::make_pair(msg, match);
      }
    std::deque<ImagePtr>& mine = is_depth ? depths_ : images_;
    mine.push_back(msg);
    if (mine.size() > kKeep) mine.pop_front();
    return {};
  }

 private:
  static constexpr size_t kKeep = 4;  // a few frames of one camera's topics out of order
  double max_dt_;
  std::deque<ImagePtr> images_, depths_;
};

std::string progressLine(const std::vector<cal::CameraSetup>& cams, const std::vector<int>& n) {
  std::ostringstream s;
  s << "frames read:";
  for (size_t i = 0; i < cams.size(); ++i) s << (i ? ", " : " ") << cams[i].name << " " << n[i];
  return s.str();
}

}  // namespace

CalibrationBagFrames readCalibrationBag(const std::string& path, const cal::TargetGeometry& target,
                                        const CalibrationBagOptions& o,
                                        const std::function<void(const std::string&)>& progress) {
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    fail("bag '", path, "' cannot be read: ", e.what());
  }
  const std::vector<std::string> cams = findCameras(bag, o, path);
  CalibrationBagFrames out;
  out.cameras = readSetups(bag, cams, o, path);
  out.frames_per_camera.assign(cams.size(), 0);
  std::map<std::string, std::pair<size_t, bool>> route;  // topic -> (camera, is depth)
  std::vector<std::string> topics;
  for (size_t i = 0; i < cams.size(); ++i) {
    const CameraTopics t = topicsOf(cams[i], o.image_topic);
    route[t.image] = {i, false};
    route[t.depth] = {i, true};
    topics.insert(topics.end(), {t.image, t.depth, stripSlash(t.image), stripSlash(t.depth)});
  }
  std::vector<Pairer> pairers(cams.size(), Pairer(o.max_pair_dt));
  // The IR amplitude images, per camera, matched to a pair's depth by stamp. The recorder writes
  // one when it arrives, which may be after its set, so a pair waits until the camera's next
  // pair (or the bag's end) before it is used.
  std::map<std::string, size_t> amplitude_route;
  if (!o.amplitude_topic.empty())
    for (size_t i = 0; i < cams.size(); ++i) {
      const std::string t = "/" + cams[i] + "/" + o.amplitude_topic;
      amplitude_route[t] = i;
      topics.insert(topics.end(), {t, stripSlash(t)});
    }
  using ImagePtr = sensor_msgs::Image::ConstPtr;
  std::vector<std::deque<ImagePtr>> amplitudes(cams.size());
  std::vector<std::pair<ImagePtr, ImagePtr>> pending(cams.size());
  std::vector<bool> amplitude_warned(cams.size(), false);
  size_t read = 0;
  const auto use = [&](size_t cam) {
    const auto [image, depth] = pending[cam];
    pending[cam] = {};
    if (!image) return;
    const CameraTopics t = topicsOf(cams[cam], o.image_topic);
    const cv::Mat gray = grayOf(*image, "bag '" + path + "': " + t.image);
    const DepthImage d = depthFromMsg(depth, "bag '" + path + "': " + t.depth);
    AmplitudeImage amplitude;
    for (const ImagePtr& a : amplitudes[cam]) {
      if (std::abs((a->header.stamp - depth->header.stamp).toSec()) > o.max_pair_dt) continue;
      const std::string where = "bag '" + path + "': /" + cams[cam] + "/" + o.amplitude_topic;
      try {
        amplitude = amplitudeFromMsg(a, where);
        if (amplitude.width != d.width || amplitude.height != d.height)
          fail(where, ": ", amplitude.width, "x", amplitude.height, " does not match the depth's ",
               d.width, "x", d.height);
      } catch (const InputError& e) {
        amplitude = AmplitudeImage();
        if (progress && !amplitude_warned[cam])
          progress(std::string(e.what()) + " (the camera's depth is used without amplitude)");
        amplitude_warned[cam] = true;
      }
      break;
    }
    out.frames.push_back(cal::extractObservation(target, out.cameras[cam], gray, d, 0,
                                                 image->header.stamp.toSec(), o.capture,
                                                 amplitude.empty() ? nullptr : &amplitude));
    ++out.frames_per_camera[cam];
    if (progress && ++read % 60 == 0) progress(progressLine(out.cameras, out.frames_per_camera));
  };
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topics))) {
    const std::string topic = "/" + stripSlash(m.getTopic());
    const auto img = m.instantiate<sensor_msgs::Image>();
    if (!img) fail("bag '", path, "': ", topic, " is not a sensor_msgs/Image");
    const auto amp = amplitude_route.find(topic);
    if (amp != amplitude_route.end()) {
      std::deque<ImagePtr>& kept = amplitudes[amp->second];
      kept.push_back(img);
      if (kept.size() > 8) kept.pop_front();  // a few sets of one camera
      continue;
    }
    const auto [cam, is_depth] = route.at(topic);
    const auto pair = pairers[cam].add(img, is_depth);
    if (!pair.first) continue;
    use(cam);  // the camera's previous pair: its amplitude has come by now
    pending[cam] = pair;
  }
  for (size_t cam = 0; cam < cams.size(); ++cam) use(cam);
  if (progress) progress(progressLine(out.cameras, out.frames_per_camera));
  return out;
}

}  // namespace drill_pipe_pose
