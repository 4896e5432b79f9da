#pragma once
// The transforms of the cycle runner from tf2, one lookup policy for the node (live TF) and
// bench_estimator (a bag's TF): /tf_static first (its latest), then the time-varying TF at the
// frame's capture stamp.

#include <geometry_msgs/TransformStamped.h>
#include <tf2/buffer_core.h>
#include <tf2_ros/buffer.h>

#include <string>

#include "drill_pipe_pose/core/cycle_runner.hpp"

namespace drill_pipe_pose {

class TfTransforms : public TransformSource {
 public:
  /// With `live` (the node's tf2_ros::Buffer, filled by a TransformListener), time-varying
  /// lookups wait up to `timeout` [s] on it; without, they use the transforms given to add().
  explicit TfTransforms(tf2_ros::Buffer* live = nullptr, double timeout = 0.0);
  /// Adds a transform (from /tf_static when is_static).
  void add(const geometry_msgs::TransformStamped& t, bool is_static);
  /// T_target_source at stamp_ns; throws tf2::TransformException naming the frames.
  Eigen::Isometry3d lookup(const std::string& target, const std::string& source,
                           int64_t stamp_ns) override;

 private:
  tf2_ros::Buffer* live_;
  double timeout_;
  tf2::BufferCore static_;                       ///< /tf_static only
  tf2::BufferCore dynamic_{ros::Duration(3600.0)};  ///< without `live`: /tf
};

}  // namespace drill_pipe_pose
