#include "drill_pipe_pose/ros/sim_messages.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <opencv2/imgproc.hpp>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/evaluation.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"

namespace drill_pipe_pose {

std::vector<geometry_msgs::TransformStamped> simStaticTransforms(const sim::RigSimulator& sim) {
  std::vector<geometry_msgs::TransformStamped> out;
  const ros::Time stamp = fromNs(sim.stampNs(0.0));
  for (size_t i = 0; i < sim.numCameras(); ++i) {
    const std::string& cam = sim.cameraName(i);
    out.push_back(toTransformMsg(sim.publishedT_world_link(i), sim.worldFrame(),
                                 conventions::linkFrame(cam), stamp));
    out.push_back(toTransformMsg(Eigen::Isometry3d::Identity(), conventions::linkFrame(cam),
                                 conventions::colorOpticalFrame(cam), stamp));
    out.push_back(toTransformMsg(sim.T_link_depth(i), conventions::colorOpticalFrame(cam),
                                 conventions::depthOpticalFrame(cam), stamp));
  }
  return out;
}

std_msgs::String simTrueJoints(const sim::RigSimulator& sim) {
  std::vector<TrueJoint> joints;
  for (const auto& e : sim.groundTruth(0.0))
    joints.push_back({e.label, e.pipe, e.nominal_od, e.rendered_od});
  std_msgs::String msg;
  msg.data = trueJointsYaml(joints);
  return msg;
}

std::vector<std::pair<std::string, geometry_msgs::PoseStamped>> simGroundTruth(
    const sim::RigSimulator& sim, double t) {
  std::vector<std::pair<std::string, geometry_msgs::PoseStamped>> out;
  for (const auto& e : sim.groundTruth(t)) {
    geometry_msgs::PoseStamped p;
    p.header.stamp = fromNs(sim.stampNs(t));
    p.header.frame_id = sim.worldFrame();
    p.pose = tf2::toMsg(e.T_world_end);
    out.emplace_back(conventions::groundTruthTopic(e.label), p);
  }
  return out;
}

KinectTopics simKinectTopics(const sim::RigSimulator& sim, size_t camera,
                             const sim::RigSimulator::Frame& frame) {
  KinectTopics k;
  const std::string& cam = sim.cameraName(camera);
  const SensorFrameData& f = frame.sensor_frame;
  if (!frame.bgr.empty()) {
    sensor_msgs::Image img;
    img.header.stamp = fromNs(f.stamp_ns);
    img.header.frame_id = f.frame_id;
    img.width = frame.color_width;
    img.height = frame.color_height;
    img.encoding = "bgr8";
    img.step = 3 * frame.color_width;
    img.data = frame.bgr;
    k.images.emplace_back(conventions::colorImageTopic(cam), std::move(img));
    k.infos.emplace_back(conventions::colorInfoTopic(cam), toMsg(f.color_info, f.stamp_ns));
  }
  k.images.emplace_back(conventions::depthImageTopic(cam),
                        toMsg(f.depth, f.depth_stamp_ns, f.depth_frame_id));
  k.infos.emplace_back(conventions::depthInfoTopic(cam), toMsg(f.depth_info, f.depth_stamp_ns));
  if (!f.amplitude.empty())
    k.images.emplace_back(conventions::amplitudeImageTopic(cam),
                          toMsg(f.amplitude, f.depth_stamp_ns, f.depth_frame_id));
  return k;
}

KinectTopics simCalibrationTopics(const sim::RigSimulator& sim, size_t camera,
                                  const sim::RigSimulator::Frame& frame) {
  const std::string& cam = sim.cameraName(camera);
  if (frame.bgr.empty()) fail("camera ", cam, ": the frame has no colour image to record");
  const SensorFrameData& f = frame.sensor_frame;
  const cv::Mat bgr(static_cast<int>(frame.color_height), static_cast<int>(frame.color_width),
                    CV_8UC3, const_cast<uint8_t*>(frame.bgr.data()));
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  sensor_msgs::Image img;
  img.header.stamp = fromNs(f.stamp_ns);
  img.header.frame_id = f.frame_id;
  img.width = frame.color_width;
  img.height = frame.color_height;
  img.encoding = "mono8";
  img.step = frame.color_width;
  img.data.assign(gray.data, gray.data + gray.total());
  KinectTopics k;
  k.images.emplace_back(conventions::hdMonoImageTopic(cam), std::move(img));
  k.infos.emplace_back(conventions::hdInfoTopic(cam), toMsg(f.color_info, f.stamp_ns));
  k.images.emplace_back(conventions::depthImageTopic(cam),
                        toMsg(f.depth, f.depth_stamp_ns, f.depth_frame_id));
  k.infos.emplace_back(conventions::depthInfoTopic(cam), toMsg(f.depth_info, f.depth_stamp_ns));
  if (!f.amplitude.empty())  // the driver's IR image beside the depth, as on a rig
    k.images.emplace_back(conventions::amplitudeImageTopic(cam),
                          toMsg(f.amplitude, f.depth_stamp_ns, f.depth_frame_id));
  return k;
}

}  // namespace drill_pipe_pose
