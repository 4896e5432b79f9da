// rig_tf_publisher: publishes the rig calibration file as static TF (world -> <cam>_link for every
// camera), through the same loader the simulator uses (core loadRigCalibration). On a rig the
// sensor nodes' kinect2_bridge publishes <cam>_link -> optical frames itself.
//   ~rig (path, required)
#include <ros/ros.h>

#include <tf2_ros/static_transform_broadcaster.h>
#include <cstdio>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/params.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "rig_tf_publisher");
  ros::NodeHandle pnh("~");
  try {
    std::string path;
    drill_pipe_pose::readParam(pnh, "rig", path);
    if (path.empty())
      drill_pipe_pose::fail("parameter ", pnh.resolveName("rig"),
                            " is missing: the rig calibration file");
    const auto rig = drill_pipe_pose::loadRigCalibration(path);
    std::vector<geometry_msgs::TransformStamped> tfs;
    for (const auto& c : rig.cameras)
      tfs.push_back(drill_pipe_pose::toTransformMsg(c.T_world_link, rig.world_frame,
                                                    drill_pipe_pose::conventions::linkFrame(c.name),
                                                    ros::Time::now()));
    tf2_ros::StaticTransformBroadcaster broadcaster;
    broadcaster.sendTransform(tfs);
    ROS_INFO("rig_tf_publisher: %zu cameras from %s as static TF %s -> <cam>_link",
             rig.cameras.size(), path.c_str(), rig.world_frame.c_str());
    ros::spin();
  } catch (const std::exception& e) {
    // Also on stderr: ROS_FATAL may not reach the console while the node shuts down.
    ROS_FATAL("rig_tf_publisher: %s", e.what());
    std::fprintf(stderr, "rig_tf_publisher: %s\n", e.what());
    return 1;
  }
  return 0;
}
