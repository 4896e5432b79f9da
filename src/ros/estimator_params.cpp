#include "drill_pipe_pose/ros/estimator_params.hpp"

#include <sstream>

#include <ros/console.h>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/ros/param_loader.hpp"

namespace drill_pipe_pose {

EstimatorConfig loadEstimatorConfig(const ros::NodeHandle& pnh) {
  EstimatorConfig c;
  loadRosParams(pnh, estimatorParamTable(), &c);
  validateConfig(c);
  return c;
}

EstimatorNodeConfig loadEstimatorNodeConfig(const ros::NodeHandle& pnh) {
  EstimatorNodeConfig c;
  loadRosParams(pnh, estimatorNodeParamTable(), &c);
  if (c.cameras.empty())
    fail("parameter ", pnh.resolveName("cameras"),
         " is missing or empty: list the sensor nodes to fuse, e.g. [cam1, cam2]");
  validateEstimatorNodeConfig(c);
  for (const auto& key : unknownRosParams(pnh, paramNames(estimatorNodeParamTable())))
    ROS_WARN("pose_estimator: parameter %s is not one of the node's parameters (misspelt?)",
             key.c_str());
  return c;
}

std::string describeEstimatorConfig(const EstimatorConfig& c) {
  std::ostringstream s;
  s << "method " << estimatorMethodName(c.method) << "; work zone [" << c.work_zone.min.transpose()
    << "] .. [" << c.work_zone.max.transpose() << "] m; tool joint OD " << c.dims.tool_joint_od
    << " m, tube OD " << c.dims.tube_od << " m; cut-out margin " << c.cutout.box_margin_px
    << " px, range " << c.cutout.min_range << ".." << c.cutout.max_range << " m, min confidence "
    << c.cutout.min_confidence << "; carving min cameras " << c.carving.min_cameras
    << ", vote fraction " << c.carving.vote_fraction << ", box reach " << c.carving.box_reach
    << " m";
  return s.str();
}

}  // namespace drill_pipe_pose
