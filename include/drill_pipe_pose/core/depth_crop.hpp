#pragma once
// Sensor-node bandwidth saver: crop a SensorFrame's depth image to the frustum of its boxes, so a
// node sends a few kilobytes instead of a full depth map. The crop is marked by depth_info.roi
// (REP 104); the central node gives the same poses with or without it, since its cut-out touches
// only the boxes' frusta.

#include <Eigen/Geometry>
#include <array>

#include "drill_pipe_pose/core/sensor_frame.hpp"

namespace drill_pipe_pose {

struct DepthCropConfig {
  double margin_px = 12.0;  ///< [colour px] boxes grown by this (covers the estimator's margins)
  double min_range = 0.3;   ///< [m] nearest depth a box pixel can have
  double max_range = 12.0;  ///< [m] farthest depth a box pixel can have
};

struct CycleCamera;

/// The depth-pixel rectangle [u0, u1) x [v0, v1) of `cam`'s delivered depth image that
/// cropDepthToBoxes keeps: the bounding rectangle of every pixel that can register into one of
/// its boxes. False when there is none.
bool depthCropRect(const CycleCamera& cam, const DepthCropConfig& config,
                   std::array<int, 4>* rect);

/// The frame with its depth cropped to the bounding rectangle of every depth pixel that can
/// register into one of its boxes (depth in [min_range, max_range]). A frame without boxes keeps
/// a single (invalid) pixel, so that depth and depth_info stay consistent. Throws InputError
/// naming the camera for an inconsistent frame.
SensorFrameData cropDepthToBoxes(const SensorFrameData& frame,
                                 const Eigen::Isometry3d& T_color_depth,
                                 const DepthCropConfig& config = {});

}  // namespace drill_pipe_pose
