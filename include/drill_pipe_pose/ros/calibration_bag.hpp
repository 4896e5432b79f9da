#pragma once
// A recorded rig calibration (launch/calibrate.launch, or simulate_bag --hd-mono) read into the
// ROS-free calibration's types: one CameraSetup per camera (intrinsics from its image's
// CameraInfo, depth intrinsics from the SD CameraInfo, T_camera_depth from /tf_static) and one
// Observation per image + depth pair (core/calibration/capture.hpp; `placement` unset: the
// grouping into placements is core/calibration/placements.hpp's).

#include <functional>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/calibration/capture.hpp"
#include "drill_pipe_pose/core/calibration/observations.hpp"

namespace drill_pipe_pose {

struct CalibrationBagOptions {
  /// The image the target is found in, relative to the camera; its CameraInfo is camera_info
  /// beside it. mono8, bgr8 or rgb8.
  std::string image_topic = "hd/image_mono_rect";
  /// Cameras to read; empty: every camera with `image_topic` in the bag.
  std::vector<std::string> cameras;
  /// [s] an image and a depth image of the same camera whose stamps differ by at most this form
  /// one frame: the recorder's synchroniser slop (nodes/record_calibration).
  double max_pair_dt = 0.02;
  /// The IR amplitude image, relative to the camera (launch/calibrate.launch records it when the
  /// driver sends it): matched to a frame's depth by stamp (within max_pair_dt) and used for the
  /// camera's weak-return bias law. Frames without one are used without; '' ignores it.
  std::string amplitude_topic = "sd/image_ir_rect";
  calibration::CaptureOptions capture;
};

struct CalibrationBagFrames {
  std::vector<calibration::CameraSetup> cameras;  ///< sorted by name
  std::vector<calibration::Observation> frames;   ///< one per image + depth pair, in bag order
  std::vector<int> frames_per_camera;             ///< per entry of `cameras`
};

/// Reads `path`. `progress` (may be empty) receives a line now and then (frames read per
/// camera). Throws InputError naming the bag and the camera / topic: an unreadable bag, no
/// image topic, a camera without CameraInfos or without its <cam>_rgb_optical_frame ->
/// <cam>_ir_optical_frame transform in /tf_static, an unsupported image encoding.
CalibrationBagFrames readCalibrationBag(const std::string& path,
                                        const calibration::TargetGeometry& target,
                                        const CalibrationBagOptions& options,
                                        const std::function<void(const std::string&)>& progress);

}  // namespace drill_pipe_pose
