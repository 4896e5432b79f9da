#pragma once
// One frame of one camera -> one Observation: the target's corners in the grey image and a
// sample of the depth pixels on the target. ROS-free; the simulator's capture tool and the
// bag-reading tool share it.

#include <opencv2/core.hpp>
#include <string>

#include "drill_pipe_pose/core/calibration/observations.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"

namespace drill_pipe_pose::calibration {

struct CaptureOptions {
  /// At most this many depth samples, spread evenly over the target (a regular pixel grid).
  /// 600: ~1 sample per 4 x 4 depth pixels of a 1.2 m board at 5-7 m, plenty for a plane's
  /// offset while keeping the observations file small.
  int max_depth_samples = 600;
  /// Fewest corners for an observation (and for the pose that places the depth samples).
  int min_corners = 6;
};

/// The observation of `camera` at `placement` (empty `corners` when the target was not found).
/// Depth samples (only when `camera.depth_intrinsics` and `depth` has pixels): the depth pixels
/// inside the target's outline shrunk by half a square, the outline placed by a cv::solvePnP
/// pose of the detected corners and camera.T_camera_depth; zero / invalid depths dropped.
Observation extractObservation(const TargetGeometry& target, const CameraSetup& camera,
                               const cv::Mat& gray, const DepthImage& depth, int placement,
                               double stamp, const CaptureOptions& options = {});

}  // namespace drill_pipe_pose::calibration
