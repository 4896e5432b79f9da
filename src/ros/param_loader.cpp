// Parameter tables from the ROS parameter server (param_loader.hpp).

#include "drill_pipe_pose/ros/param_loader.hpp"

#include <XmlRpcValue.h>
#include <ros/param.h>

#include <algorithm>
#include <cmath>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

namespace {

[[noreturn]] void failType(const ros::NodeHandle& nh, const ParamInfo& info) {
  fail("parameter ", nh.resolveName(info.name), ": expected ", paramTypeExpected(info.type));
}

bool toDouble(XmlRpc::XmlRpcValue& v, double* d) {
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) *d = static_cast<double>(v);
  else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) *d = static_cast<int>(v);
  else return false;
  return true;
}

std::vector<double> toDoubles(const ros::NodeHandle& nh, const ParamInfo& info,
                              XmlRpc::XmlRpcValue& v) {
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) failType(nh, info);
  std::vector<double> out(v.size());
  for (int i = 0; i < v.size(); ++i)
    if (!toDouble(v[i], &out[i])) failType(nh, info);
  return out;
}

}  // namespace

ParamValue readRosParam(const ros::NodeHandle& nh, const ParamInfo& info) {
  XmlRpc::XmlRpcValue v;
  if (!nh.getParam(info.name, v)) failType(nh, info);
  using X = XmlRpc::XmlRpcValue;
  switch (info.type) {
    case ParamType::kBool:
      if (v.getType() != X::TypeBoolean) failType(nh, info);
      return static_cast<bool>(v);
    case ParamType::kInt: {
      // An integral double (e.g. 2.0) is accepted, as the hand-written loader did.
      double d;
      if (!toDouble(v, &d) || d != std::floor(d)) failType(nh, info);
      return static_cast<long long>(d);
    }
    case ParamType::kDouble: {
      double d;
      if (!toDouble(v, &d)) failType(nh, info);
      return d;
    }
    case ParamType::kString:
    case ParamType::kEnum:
      if (v.getType() != X::TypeString) failType(nh, info);
      return static_cast<std::string>(v);
    case ParamType::kVec3: {
      const auto d = toDoubles(nh, info, v);
      if (d.size() != 3) failType(nh, info);
      return Eigen::Vector3d(d[0], d[1], d[2]);
    }
    case ParamType::kDoubleList: return toDoubles(nh, info, v);
    case ParamType::kStringList: {
      if (v.getType() != X::TypeArray) failType(nh, info);
      std::vector<std::string> out;
      for (int i = 0; i < v.size(); ++i) {
        if (v[i].getType() != X::TypeString) failType(nh, info);
        out.push_back(static_cast<std::string>(v[i]));
      }
      return out;
    }
  }
  failType(nh, info);
}

std::vector<std::string> unknownRosParams(const ros::NodeHandle& nh,
                                          const std::vector<std::string>& known) {
  std::vector<std::string> all, unknown;
  if (!ros::param::getParamNames(all)) return unknown;
  const std::string ns = nh.getNamespace() == "/" ? "/" : nh.getNamespace() + "/";
  for (const auto& name : all) {
    if (name.compare(0, ns.size(), ns) != 0) continue;
    const std::string key = name.substr(ns.size());
    const bool is_known = std::any_of(known.begin(), known.end(), [&](const std::string& k) {
      return key == k || key.compare(0, k.size() + 1, k + "/") == 0;
    });
    if (!is_known) unknown.push_back(name);
  }
  return unknown;
}

}  // namespace drill_pipe_pose
