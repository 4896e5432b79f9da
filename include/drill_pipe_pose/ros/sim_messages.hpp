#pragma once
// ROS messages of the simulated rig, shared by the live rig_simulator node and simulate_bag so
// that a bag and a live run carry exactly the same topics, frames and stamps.

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>

#include <string>
#include <utility>
#include <vector>

#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

namespace drill_pipe_pose {

/// Static TF of the simulated rig, as kinect2_bridge + the rig calibration would publish it:
/// world -> <cam>_link (PUBLISHED calibration), <cam>_link -> <cam>_rgb_optical_frame (identity),
/// <cam>_rgb_optical_frame -> <cam>_ir_optical_frame (the sensor's colour-to-depth calibration).
std::vector<geometry_msgs::TransformStamped> simStaticTransforms(const sim::RigSimulator& sim);

/// The scored joints as rendered (TrueJoint; kGroundTruthJointsTopic): what a measured OD is
/// judged against.
std_msgs::String simTrueJoints(const sim::RigSimulator& sim);

/// (topic, message) ground truth of every pipe end at simulation time t [s], stamped as the
/// simulator stamps its frames.
std::vector<std::pair<std::string, geometry_msgs::PoseStamped>> simGroundTruth(
    const sim::RigSimulator& sim, double t);

/// The kinect2_bridge-style topics of a rendered frame: (topic, message) for the QHD colour image
/// and info (only when the frame has colour) and the SD depth image and info.
struct KinectTopics {
  std::vector<std::pair<std::string, sensor_msgs::Image>> images;
  std::vector<std::pair<std::string, sensor_msgs::CameraInfo>> infos;
};
KinectTopics simKinectTopics(const sim::RigSimulator& sim, size_t camera,
                             const sim::RigSimulator::Frame& frame);
/// What the rig calibration records of a rendered frame (the simulator rendering colour at HD,
/// SimulatorOptions::color_scale = 2): the HD grey image (mono8, converted from the colour as
/// kinect2_bridge's image_mono is) and its info, the SD depth image and its info, and the IR
/// amplitude image (sd/image_ir_rect) when the frame carries one. Throws
/// InputError naming the camera when the frame has no colour.
KinectTopics simCalibrationTopics(const sim::RigSimulator& sim, size_t camera,
                                  const sim::RigSimulator::Frame& frame);


}  // namespace drill_pipe_pose
