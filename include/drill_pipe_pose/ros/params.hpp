#pragma once
// Typed parameter reading: a missing parameter keeps the default, a parameter of the wrong type
// is an error naming the node's namespace, the key and the expected type (never a silent default).

#include <ros/node_handle.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

namespace detail {
inline const char* typeName(const bool*) {
  return "a boolean";
}
inline const char* typeName(const int*) {
  return "an integer";
}
inline const char* typeName(const double*) {
  return "a number";
}
inline const char* typeName(const std::string*) {
  return "a string";
}
inline const char* typeName(const std::vector<std::string>*) {
  return "a list of strings";
}
inline const char* typeName(const std::vector<double>*) {
  return "a list of numbers";
}
}  // namespace detail

/// Reads `key` into `value` when set; throws InputError when it has the wrong type.
template <typename T>
void readParam(const ros::NodeHandle& nh, const std::string& key, T& value) {
  if (!nh.hasParam(key)) return;
  T v;
  if (!nh.getParam(key, v))
    fail("parameter ", nh.resolveName(key), ": expected ", detail::typeName(&v));
  value = v;
}

/// Unsigned / float / size_t fields through int / double, with a range check.
template <typename T>
void readNumber(const ros::NodeHandle& nh, const std::string& key, T& value, double min_value) {
  if (!nh.hasParam(key)) return;
  double v;
  if (!nh.getParam(key, v)) fail("parameter ", nh.resolveName(key), ": expected a number");
  if (!(v >= min_value))
    fail("parameter ", nh.resolveName(key), " = ", v, ": must be >= ", min_value);
  value = static_cast<T>(v);
}

/// A 3-vector from a list of 3 numbers.
inline void readVector3(const ros::NodeHandle& nh, const std::string& key, Eigen::Vector3d& value) {
  if (!nh.hasParam(key)) return;
  std::vector<double> v;
  if (!nh.getParam(key, v) || v.size() != 3)
    fail("parameter ", nh.resolveName(key), ": expected a list of 3 numbers [x, y, z]");
  value = Eigen::Vector3d(v[0], v[1], v[2]);
}

}  // namespace drill_pipe_pose
