#include "drill_pipe_pose/ros/estimator_params.hpp"

#include <sstream>

#include <ros/console.h>
#include <ros/package.h>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/ros/param_loader.hpp"

namespace drill_pipe_pose {

EstimatorConfig loadEstimatorConfig(const ros::NodeHandle& pnh) {
  EstimatorConfig c;
  loadRosParams(pnh, estimatorParamTable(), &c);
  validateConfig(c);
  return c;
}

void defaultPipeCatalog(EstimatorConfig* config) {
  if (config->pipe_catalog.empty())
    config->pipe_catalog = ros::package::getPath("drill_pipe_pose") + "/config/pipe_catalog.yaml";
}

EstimatorNodeConfig loadEstimatorNodeConfig(const ros::NodeHandle& pnh) {
  EstimatorNodeConfig c;
  loadRosParams(pnh, estimatorNodeParamTable(), &c);
  defaultPipeCatalog(&c.estimator);
  if (c.cameras.empty())
    fail("parameter ", pnh.resolveName("cameras"),
         " is missing or empty: list the sensor nodes to fuse, e.g. [cam1, cam2]");
  validateEstimatorNodeConfig(c);
  for (const auto& key : unknownRosParams(pnh, paramNames(estimatorNodeParamTable())))
    ROS_WARN("pose_estimator: parameter %s is not one of the node's parameters (misspelt?)",
             key.c_str());
  return c;
}

namespace {
std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}
}  // namespace

std::string describeEstimatorConfig(const EstimatorConfig& c) {
  std::ostringstream s;
  s << "method " << estimatorMethodName(c.method) << "; work zone [" << c.work_zone.min.transpose()
    << "] .. [" << c.work_zone.max.transpose() << "] m; tool joint OD " << c.dims.tool_joint_od
    << " m, tube OD " << c.dims.tube_od << " m; pipe type " << (c.pipe_type.empty() ? "-" : c.pipe_type)
    << " among [" << joined(c.pipe_types) << "] (" << c.pipe_catalog << "); cut-out margin " << c.cutout.box_margin_px
    << " px, range " << c.cutout.min_range << ".." << c.cutout.max_range << " m, min confidence "
    << c.cutout.min_confidence << "; carving min cameras " << c.carving.min_cameras
    << ", vote fraction " << c.carving.vote_fraction << ", box reach " << c.carving.box_reach
    << " m";
  return s.str();
}

}  // namespace drill_pipe_pose
