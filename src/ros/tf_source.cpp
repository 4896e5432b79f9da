#include "drill_pipe_pose/ros/tf_source.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include "drill_pipe_pose/ros/conversions.hpp"

namespace drill_pipe_pose {

TfTransforms::TfTransforms(tf2_ros::Buffer* live, double timeout)
    : live_(live), timeout_(timeout) {}

void TfTransforms::add(const geometry_msgs::TransformStamped& t, bool is_static) {
  if (is_static)
    static_.setTransform(t, "tf_static", true);
  else
    dynamic_.setTransform(t, "tf", false);
}

Eigen::Isometry3d TfTransforms::lookup(const std::string& target, const std::string& source,
                                       int64_t stamp_ns) {
  try {
    return tf2::transformToEigen(static_.lookupTransform(target, source, ros::Time(0)));
  } catch (const tf2::TransformException&) {
    if (live_)
      return tf2::transformToEigen(
          live_->lookupTransform(target, source, fromNs(stamp_ns), ros::Duration(timeout_)));
    return tf2::transformToEigen(dynamic_.lookupTransform(target, source, fromNs(stamp_ns)));
  }
}

}  // namespace drill_pipe_pose
