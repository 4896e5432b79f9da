#pragma once
// Type-checked YAML access for the simulator's config files: every error names the file (and
// the path of the key inside it), the key and what was expected. Internal to the simulator.

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <cmath>
#include <string>
#include <typeinfo>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose::sim {

template <typename T>
inline const char* yamlTypeName() {
  if constexpr (std::is_same_v<T, std::string>) return "a string";
  if constexpr (std::is_same_v<T, bool>) return "a boolean";
  if constexpr (std::is_integral_v<T>) return "an integer";
  if constexpr (std::is_floating_point_v<T>) return "a number";
  return "a value";
}

/// Loads a YAML file; InputError naming the file on read or syntax errors.
inline YAML::Node yamlLoadFile(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    fail(path, ": cannot read the file");
  } catch (const YAML::Exception& e) {
    fail(path, ": YAML syntax error: ", e.what());
  }
}

/// Converts a node to T; InputError "<where>: <key>: expected <type>" on a wrong type.
template <typename T>
inline T yamlAs(const YAML::Node& n, const std::string& key, const std::string& where) {
  if (!n.IsScalar()) fail(where, ": ", key, ": expected ", yamlTypeName<T>());
  try {
    const T v = n.as<T>();
    if constexpr (std::is_floating_point_v<T>)
      if (!std::isfinite(v)) fail(where, ": ", key, ": expected a finite number, got ", v);
    return v;
  } catch (const YAML::Exception&) {
    fail(where, ": ", key, ": expected ", yamlTypeName<T>(), ", got \"", n.Scalar(), "\"");
  }
}

/// Required key.
template <typename T>
inline T yamlGet(const YAML::Node& map, const std::string& key, const std::string& where) {
  if (!map.IsMap()) fail(where, ": expected a map with key \"", key, "\"");
  const YAML::Node n = map[key];
  if (!n) fail(where, ": missing key \"", key, "\"");
  return yamlAs<T>(n, key, where);
}

/// Optional key with a default.
template <typename T>
inline T yamlGetOr(const YAML::Node& map, const std::string& key, const T& def,
                   const std::string& where) {
  if (!map.IsMap()) fail(where, ": expected a map");
  const YAML::Node n = map[key];
  if (!n) return def;
  return yamlAs<T>(n, key, where);
}

/// Required child node.
inline YAML::Node yamlChild(const YAML::Node& map, const std::string& key,
                            const std::string& where) {
  if (!map.IsMap()) fail(where, ": expected a map with key \"", key, "\"");
  const YAML::Node n = map[key];
  if (!n) fail(where, ": missing key \"", key, "\"");
  return n;
}

/// A sequence of exactly N finite numbers.
template <int N>
inline Eigen::Matrix<double, N, 1> yamlVector(const YAML::Node& n, const std::string& key,
                                              const std::string& where) {
  if (!n.IsSequence() || static_cast<int>(n.size()) != N)
    fail(where, ": ", key, ": expected a sequence of ", N, " numbers");
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i)
    v[i] = yamlAs<double>(n[i], key + "[" + std::to_string(i) + "]", where);
  return v;
}

inline Eigen::Vector3d yamlVec3(const YAML::Node& map, const std::string& key,
                                const std::string& where) {
  return yamlVector<3>(yamlChild(map, key, where), key, where);
}

/// Unit quaternion [x, y, z, w] (tolerance 1e-3, then normalised).
inline Eigen::Quaterniond yamlQuaternion(const YAML::Node& map, const std::string& key,
                                         const std::string& where) {
  const Eigen::Vector4d q = yamlVector<4>(yamlChild(map, key, where), key, where);
  if (std::abs(q.norm() - 1.0) > 1e-3)
    fail(where, ": ", key, ": expected a unit quaternion [x, y, z, w], norm is ", q.norm());
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized();
}

}  // namespace drill_pipe_pose::sim
