// rostest: a SensorFrame published by another process through a real master arrives intact.
// The same binary is the publisher when started with --publish (see sensor_frame_transport.test),
// so the message crosses a real process boundary and real serialisation.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include "drill_pipe_pose/ros/conversions.hpp"
#include "sample_messages.hpp"

TEST(SensorFrameTransport, ArrivesIntact) {
  ros::NodeHandle nh;
  drill_pipe_pose::SensorFrameConstPtr received;
  auto sub = nh.subscribe<drill_pipe_pose::SensorFrame>(
      "cam3/sensor_frame", 1, [&](const drill_pipe_pose::SensorFrameConstPtr& m) { received = m; });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  while (!received && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  ASSERT_TRUE(received) << "no SensorFrame on cam3/sensor_frame within 20 s";
  const auto expected = drill_pipe_pose_test::sampleSensorFrame("cam3", 9);
  // roscpp numbers the top-level header on publish; everything else must be byte-identical.
  auto copy = *received;
  EXPECT_GT(copy.header.seq, 0u);
  copy.header.seq = 0;
  EXPECT_EQ(drill_pipe_pose_test::serialize(copy), drill_pipe_pose_test::serialize(expected));
  // And it converts to the core form without loss.
  const auto data = drill_pipe_pose::fromMsg(received);
  EXPECT_EQ(data.camera, "cam3");
  EXPECT_EQ(data.boxes.size(), 2u);
  EXPECT_EQ(drill_pipe_pose_test::serialize(drill_pipe_pose::toMsg(data)),
            drill_pipe_pose_test::serialize(expected));
}

namespace {

// Publishes the deterministic sample SensorFrame of ~camera / ~seed at 10 Hz until shutdown.
int runPublisher() {
  ros::NodeHandle nh, pnh("~");
  const std::string camera = pnh.param<std::string>("camera", "cam1");
  const int seed = pnh.param("seed", 5);
  ros::Publisher pub = nh.advertise<drill_pipe_pose::SensorFrame>(camera + "/sensor_frame", 1);
  const auto msg = drill_pipe_pose_test::sampleSensorFrame(camera, static_cast<unsigned>(seed));
  ros::Rate rate(10.0);
  while (ros::ok()) {
    pub.publish(msg);
    rate.sleep();
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "--publish") {
    ros::init(argc, argv, "sample_sensor_frame_publisher");
    return runPublisher();
  }
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sensor_frame_transport");
  return RUN_ALL_TESTS();
}
