// rig_simulator: publishes what a simulated rig's sensor nodes would publish, live, with ground
// truth. Parameters (private): the table in sim/simulator_node_params.hpp (docs/parameters.md lists it).
// When rendering cannot keep up with `rate`, simulation time (and /clock) slows down to what it
// can render (with publish_clock), or frames are skipped with a throttled warning (without).
#include <drill_pipe_pose/SensorFrame.h>
#include <ros/package.h>
#include <ros/ros.h>

#include <rosgraph_msgs/Clock.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <cstdio>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/param_loader.hpp"
#include "drill_pipe_pose/ros/sim_messages.hpp"
#include "drill_pipe_pose/sim/simulator_node_params.hpp"

namespace drill_pipe_pose {
namespace {

class RigSimulatorNode {
 public:
  explicit RigSimulatorNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh) {
    const std::string pkg = ros::package::getPath("drill_pipe_pose");
    RigSimulatorNodeConfig p;  // the parameter table: sim/simulator_node_params.hpp
    loadRosParams(pnh, rigSimulatorParamTable(), &p);
    const std::string rig = p.rig.empty() ? pkg + "/config/rigs/thesis_lab.yaml" : p.rig;
    const std::string& scene = p.scene;
    sim::SimulatorOptions opt = p.options;
    opt.sensor_config_dir = pkg + "/config/sensors";
    const int seed = static_cast<int>(opt.seed);
    crop_ = p.crop;
    rate_ = p.rate;
    publish_clock_ = p.publish_clock;
    duration_ = p.duration;
    if (scene.empty())
      fail("parameter ", pnh.resolveName("scene"),
           " is missing: a scene file, e.g. $(find "
           "drill_pipe_pose)/config/scenes/thesis_vertical.yaml");
    for (const auto& key : unknownRosParams(pnh, paramNames(rigSimulatorParamTable())))
      ROS_WARN("rig_simulator: parameter %s is not one of the node's parameters (misspelt?)",
               key.c_str());
    opt.stamp_origin_ns = publish_clock_ ? 1000000000LL : toNs(ros::Time::now());
    sim_ = sim::loadScenario(rig, scene, opt);

    for (size_t i = 0; i < sim_->numCameras(); ++i) {
      const std::string& cam = sim_->cameraName(i);
      if (opt.simulated_detection)
        frame_pubs_.push_back(nh_.advertise<SensorFrame>(conventions::sensorFrameTopic(cam), 5));
    }
    if (publish_clock_) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
    static_tf_.sendTransform(simStaticTransforms(*sim_));
    // The joints as rendered (their worn ODs), latched: a recording of a live run has them too.
    joints_pub_ = nh_.advertise<std_msgs::String>(conventions::kGroundTruthJointsTopic, 1, true);
    joints_pub_.publish(simTrueJoints(*sim_));
    ROS_INFO(
        "rig_simulator: %zu cameras (rig %s), scene %s, profile %s, seed %d, simulated "
        "detection %s, colour %s, crop %s, rate %.2f, %s",
        sim_->numCameras(), rig.c_str(), scene.c_str(), opt.profile.c_str(), seed,
        opt.simulated_detection ? "on" : "off", opt.color ? "on" : "off", crop_ ? "on" : "off",
        rate_, publish_clock_ ? "publishing /clock" : "stamped with wall time");
    wall0_ = ros::WallTime::now();
    timer_ = nh_.createWallTimer(ros::WallDuration(0.002),
                                 [this](const ros::WallTimerEvent&) { step(); });
  }

 private:
  void step() {
    const double target = (ros::WallTime::now() - wall0_).toSec() * rate_;
    const double until = duration_ > 0 ? std::min(target, duration_) : target;
    if (until <= t_done_) {
      if (duration_ > 0 && t_done_ >= duration_ && !finished_) {
        finished_ = true;
        ROS_INFO("rig_simulator: %.1f s simulated, done", duration_);
      }
      return;
    }
    const ros::WallTime start = ros::WallTime::now();
    for (const auto& c : sim_->captures(t_done_, until)) {
      // Never let one step run for long: the rest of the captures go to the next step.
      if ((ros::WallTime::now() - start).toSec() > 0.1) {
        if (!publish_clock_) {
          ROS_WARN_THROTTLE(10.0,
                            "rig_simulator: rendering is behind real time; frames skipped "
                            "(throttled, 10 s): lower ~rate or use ~publish_clock");
          t_done_ = until;
          wall0_ = ros::WallTime::now() - ros::WallDuration(until / rate_);
        } else {
          wall0_ = ros::WallTime::now() - ros::WallDuration(t_done_ / rate_);  // slow the clock
        }
        return;
      }
      publishCapture(c);
      t_done_ = c.t + 1e-9;
    }
    t_done_ = until;
  }

  void publishCapture(const sim::Capture& c) {
    if (publish_clock_) {
      rosgraph_msgs::Clock clock;
      clock.clock = fromNs(sim_->stampNs(c.t));
      clock_pub_.publish(clock);
    }
    sim::RigSimulator::Frame frame = sim_->render(c.camera, c.t, c.frame_index);
    if (!frame_pubs_.empty()) {
      const SensorFrameData& sf =
          crop_ ? cropDepthToBoxes(frame.sensor_frame, sim_->T_link_depth(c.camera))
                : frame.sensor_frame;
      frame_pubs_[c.camera].publish(toMsg(sf));
    }
    if (sim_->options().color) {
      const KinectTopics k = simKinectTopics(*sim_, c.camera, frame);
      for (const auto& [topic, img] : k.images) publisher<sensor_msgs::Image>(topic).publish(img);
      for (const auto& [topic, info] : k.infos)
        publisher<sensor_msgs::CameraInfo>(topic).publish(info);
    }
    for (const auto& [topic, pose] : simGroundTruth(*sim_, c.t))
      publisher<geometry_msgs::PoseStamped>(topic).publish(pose);
  }

  template <typename M>
  ros::Publisher& publisher(const std::string& topic) {
    auto it = pubs_.find(topic);
    if (it == pubs_.end()) it = pubs_.emplace(topic, nh_.advertise<M>(topic, 5)).first;
    return it->second;
  }

  ros::NodeHandle nh_;
  std::unique_ptr<sim::RigSimulator> sim_;
  std::vector<ros::Publisher> frame_pubs_;
  std::map<std::string, ros::Publisher> pubs_;
  ros::Publisher clock_pub_;
  ros::Publisher joints_pub_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  ros::WallTimer timer_;
  ros::WallTime wall0_;
  double rate_ = 1.0, duration_ = 0.0, t_done_ = 0.0;
  bool crop_ = false, publish_clock_ = false, finished_ = false;
};

}  // namespace
}  // namespace drill_pipe_pose

int main(int argc, char** argv) {
  ros::init(argc, argv, "rig_simulator");
  try {
    drill_pipe_pose::RigSimulatorNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    // Also on stderr: ROS_FATAL may not reach the console while the node shuts down.
    ROS_FATAL("rig_simulator: %s", e.what());
    std::fprintf(stderr, "rig_simulator: %s\n", e.what());
    return 1;
  }
  return 0;
}
