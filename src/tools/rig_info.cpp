// rig_info: validates a rig calibration file and prints each camera's pose and its distance and
// viewing angle to the work zone (or any point).
//
//   rosrun drill_pipe_pose rig_info RIG.yaml [--target x y z] [--zone x0 y0 z0 x1 y1 z1]
//
// Off-axis angle: between the camera's optical axis and the ray to the target (a Kinect v2 depth
// camera sees +-35 deg horizontally, +-30 deg vertically). Depression: how far below the
// horizon the camera looks at the target. The default zone is the thesis lab's
// (config/estimator_thesis_lab.yaml). Exit status 0; 1 on a bad calibration file; 2 on a bad
// command line.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "cli.hpp"

int main(int argc, char** argv) {
  std::string path;
  std::vector<double> target_xyz, zone{2.7, 4.0, 0.0, 6.7, 8.1, 3.0};  // the thesis lab's zone
  CLI::App app{"Validates a rig calibration file and prints each camera's pose, distance and "
               "viewing angles to the work zone (or a target point).",
               "rig_info"};
  drill_pipe_pose::tools::configureApp(app);
  app.add_option("RIG", path, "rig calibration file (YAML)")->required()->check(CLI::ExistingFile);
  app.add_option("--target", target_xyz, "[m] world point to look at (default: the zone's centre)")
      ->expected(3)
      ->option_text("x y z");
  app.add_option("--zone", zone, "[m] work zone, min and max corner (default: the thesis lab's)")
      ->expected(6)
      ->option_text("x0 y0 z0 x1 y1 z1");
  drill_pipe_pose::tools::parseOrExit(app, argc, argv);
  if (!target_xyz.empty() && target_xyz.size() != 3)
    drill_pipe_pose::tools::usageError(app, "--target: expected 3 numbers: x y z");
  if (const std::string bad = drill_pipe_pose::tools::boxError(zone); !bad.empty())
    drill_pipe_pose::tools::usageError(app, "--zone: " + bad);
  const Eigen::Vector3d zmin(zone[0], zone[1], zone[2]), zmax(zone[3], zone[4], zone[5]);
  const bool have_target = !target_xyz.empty();
  Eigen::Vector3d target;
  if (have_target) target = Eigen::Vector3d(target_xyz[0], target_xyz[1], target_xyz[2]);
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
