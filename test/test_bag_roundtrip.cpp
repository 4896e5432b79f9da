// simulate_bag round trip: the bag holds, for every capture of the schedule, exactly the frame the
// simulator renders for it (byte-identical SensorFrame), the latched static TF and ground truth
// (each end's pose, and each joint's OD as rendered);
// and a bag of SensorFrame's definition before its amplitude field still reads.
#include <drill_pipe_pose/SensorFrame.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <cstdio>
#include <cstdlib>
#include <map>

#include "drill_pipe_pose/core/evaluation.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"
#include "sample_messages.hpp"

using namespace drill_pipe_pose;

namespace {

template <typename M>
std::vector<uint8_t> bytes(const M& m) {
  std::vector<uint8_t> b(ros::serialization::serializationLength(m));
  ros::serialization::OStream s(b.data(), b.size());
  ros::serialization::serialize(s, m);
  return b;
}

}  // namespace

TEST(SimulateBag, RoundTripIsExact) {
  const std::string src = DRILL_PIPE_POSE_SOURCE_DIR;
  const std::string bag_path = testing::TempDir() + "dpp_roundtrip.bag";
  const unsigned seed = 4;
  const std::string cmd = std::string(SIMULATE_BAG) + " --scene " + src +
                          "/config/scenes/thesis_vertical.yaml --rig " + src +
                          "/config/rigs/thesis_lab.yaml --sensors " + src +
                          "/config/sensors --duration 0.2 --seed " + std::to_string(seed) +
                          " --quiet --out " + bag_path + " > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  sim::SimulatorOptions opt;
  opt.seed = seed;
  opt.sensor_config_dir = src + "/config/sensors";
  opt.stamp_origin_ns = 1000000000;  // as simulate_bag
  auto sim = sim::loadScenario(src + "/config/rigs/thesis_lab.yaml",
                               src + "/config/scenes/thesis_vertical.yaml", opt);

  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  std::map<std::string, std::vector<SensorFrameConstPtr>> frames;
  size_t tf_static = 0, truth = 0;
  std::vector<std::vector<TrueJoint>> joints;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    if (auto f = m.instantiate<SensorFrame>()) {
      frames[f->camera].push_back(f);
      EXPECT_EQ(m.getTopic(), "/" + f->camera + "/sensor_frame");
    } else if (auto t = m.instantiate<tf2_msgs::TFMessage>()) {
      ++tf_static;
      EXPECT_EQ(m.getTopic(), "/tf_static");
      EXPECT_EQ(m.getConnectionHeader()->at("latching"), "1");
      EXPECT_EQ(t->transforms.size(), 3 * sim->numCameras());
    } else if (m.instantiate<geometry_msgs::PoseStamped>()) {
      ++truth;
    } else if (auto s = m.instantiate<std_msgs::String>()) {
      EXPECT_EQ(m.getTopic(), conventions::kGroundTruthJointsTopic);
      joints.push_back(parseTrueJoints(s->data));
    }
  }
  EXPECT_EQ(tf_static, 1u);
  // Each scored joint's OD as rendered, once: its wear (0-2 mm) below the scene file's.
  ASSERT_EQ(joints.size(), 1u);
  const auto ends = sim->groundTruth(0.0);
  ASSERT_EQ(joints[0].size(), ends.size());
  for (size_t i = 0; i < ends.size(); ++i) {
    EXPECT_EQ(joints[0][i].label, ends[i].label) << i;
    EXPECT_EQ(joints[0][i].pipe, ends[i].pipe) << i;
    EXPECT_NEAR(joints[0][i].rendered_od, sim->scene().ends[i].rendered.tool_joint_od, 1e-9) << i;
    EXPECT_NEAR(joints[0][i].nominal_od, 0.168275, 1e-9) << i;  // the 5" NC50's
    EXPECT_GT(joints[0][i].nominal_od - joints[0][i].rendered_od, 0.0)
        << i << " (seed " << seed << ")";
    EXPECT_LE(joints[0][i].nominal_od - joints[0][i].rendered_od, 0.002) << i;
  }
  const auto captures = sim->captures(0.0, 0.2);
  ASSERT_FALSE(captures.empty());
  EXPECT_EQ(truth, 2 * captures.size());  // both ends at every capture
  std::map<std::string, size_t> next;
  for (const auto& c : captures) {
    const std::string& cam = sim->cameraName(c.camera);
    ASSERT_LT(next[cam], frames[cam].size()) << cam << " (seed " << seed << ")";
    const SensorFrame expected = toMsg(sim->render(c.camera, c.t, c.frame_index).sensor_frame);
    EXPECT_EQ(bytes(*frames[cam][next[cam]++]), bytes(expected))
        << cam << " at t = " << c.t << " (seed " << seed << ")";
  }
  std::remove(bag_path.c_str());
}

TEST(SimulateBag, ABagOfTheDefinitionBeforeAmplitudeStillReads) {
  // What a bag recorded before SensorFrame's amplitude field holds: the older definition's MD5.
  const std::string bag_path = testing::TempDir() + "dpp_legacy.bag";
  const SensorFrame now = drill_pipe_pose_test::sampleSensorFrame("cam2", 9);
  const LegacySensorFrame old = drill_pipe_pose_test::legacyOf(now);
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    bag.write("/cam2/sensor_frame", ros::Time(5), old);
    bag.write("/cam2/sensor_frame", ros::Time(6), now);
  }
  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  std::vector<SensorFrameConstPtr> read;
  for (const rosbag::MessageInstance& m : rosbag::View(bag))
    if (auto f = sensorFrameOf(m)) read.push_back(f);
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(bytes(*read[0]), bytes(now));  // upgraded: no amplitude
  EXPECT_EQ(bytes(*read[1]), bytes(now));
  EXPECT_TRUE(fromMsg(read[0]).amplitude.empty());
  std::remove(bag_path.c_str());
}
