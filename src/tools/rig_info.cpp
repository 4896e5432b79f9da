// rig_info: validates a rig calibration file and prints each camera's pose and its distance and
// viewing angle to the work zone (or any point).
//
//   rosrun drill_pipe_pose rig_info RIG.yaml [--target x y z] [--zone x0 y0 z0 x1 y1 z1]
//
// Off-axis angle: between the camera's optical axis and the ray to the target (a Kinect v2 depth
// camera sees +-35 deg horizontally, +-30 deg vertically). Depression: how far below the
// horizon the camera looks at the target.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"

int main(int argc, char** argv) {
  std::string path;
  Eigen::Vector3d zmin(2.7, 4.0, 0.0), zmax(6.7, 8.1, 3.0);
  bool have_target = false;
  Eigen::Vector3d target;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--target" && i + 3 < argc) {
      for (int k = 0; k < 3; ++k) target[k] = std::stod(argv[++i]);
      have_target = true;
    } else if (a == "--zone" && i + 6 < argc) {
      for (int k = 0; k < 3; ++k) zmin[k] = std::stod(argv[++i]);
      for (int k = 0; k < 3; ++k) zmax[k] = std::stod(argv[++i]);
    } else if (path.empty()) {
      path = a;
    } else {
      path.clear();
      break;
    }
  }
  if (path.empty()) {
    std::cerr << "usage: rig_info RIG.yaml [--target x y z] [--zone x0 y0 z0 x1 y1 z1]\n";
    return 2;
  }
  try {
    const auto rig = drill_pipe_pose::loadRigCalibration(path);
    if (!have_target) target = 0.5 * (zmin + zmax);
    std::printf("%s: %zu cameras, world frame '%s'; target (%.3f, %.3f, %.3f) m\n", path.c_str(),
                rig.cameras.size(), rig.world_frame.c_str(), target.x(), target.y(), target.z());
    std::printf("%-8s %24s %22s %9s %9s %11s %s\n", "camera", "position [m]", "axis (world)",
                "dist [m]", "off [deg]", "depr. [deg]", "zone corners in view (+-35x30 deg)");
    for (const auto& c : rig.cameras) {
      const Eigen::Vector3d p = c.T_world_link.translation();
      const Eigen::Vector3d axis = c.T_world_link.linear().col(2);
      const Eigen::Vector3d to = target - p;
      const double dist = to.norm();
      const double off = std::acos(std::clamp(axis.dot(to) / dist, -1.0, 1.0)) * 180 / M_PI;
      const double depression = std::asin(std::clamp(-to.z() / dist, -1.0, 1.0)) * 180 / M_PI;
      int seen = 0;
      for (int k = 0; k < 8; ++k) {
        const Eigen::Vector3d corner((k & 1) ? zmax.x() : zmin.x(), (k & 2) ? zmax.y() : zmin.y(),
                                     (k & 4) ? zmax.z() : zmin.z());
        const Eigen::Vector3d q = c.T_world_link.inverse() * corner;  // optical frame
        if (q.z() > 0 && std::abs(std::atan2(q.x(), q.z())) < 35.3 * M_PI / 180 &&
            std::abs(std::atan2(q.y(), q.z())) < 30.0 * M_PI / 180)
          ++seen;
      }
      std::printf(
          "%-8s (%6.3f, %6.3f, %6.3f)  (%5.2f, %5.2f, %5.2f) %9.2f %9.1f %11.1f %d of 8%s\n",
          c.name.c_str(), p.x(), p.y(), p.z(), axis.x(), axis.y(), axis.z(), dist, off, depression,
          seen, dist > 8.0 ? "  WARNING: beyond 8 m (set the driver's max depth higher)" : "");
    }
  } catch (const drill_pipe_pose::InputError& e) {
    std::cerr << "rig_info: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
