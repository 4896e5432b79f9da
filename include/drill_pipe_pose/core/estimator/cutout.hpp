#pragma once
// Stage "cut-out": a cycle's validated cameras and, per camera, the depth pixels that register
// into its detection boxes, in the world frame [m].

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"

namespace drill_pipe_pose {

/// A cut-out point.
struct CloudPoint {
  Eigen::Vector3f p_world;  ///< [m] world
  float sigma = 0.01f;      ///< [m] expected depth-noise std of this point
  uint16_t camera = 0;      ///< index of the camera (in the cycle's camera list)
};

/// A validated camera of one cycle: models, transforms, boxes (already confidence-filtered).
struct CycleCamera {
  std::string name;
  int64_t stamp_ns = 0;  ///< the frame's capture stamp (SensorFrameData::stamp_ns)
  PinholeCamera depth;
  PinholeCamera color;
  DepthImage image;
  AmplitudeImage amplitude;  ///< on image's grid; empty when the frame carries none
  /// [m (1/m^2)^4] the camera's weak-return B (DepthCorrection::weak_return_bias; < 0: the
  /// sensor's fitted one).
  double weak_return_bias = -1.0;
  Eigen::Isometry3d T_world_depth = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_color_depth = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_color_world = Eigen::Isometry3d::Identity();  ///< derived
  std::vector<DetectionBox> boxes;
  /// Whether this camera has at least one box of each label.
  std::array<bool, kNumEnds> has_label{{false, false}};
  /// [u0, v0, u1) x [v0, v1) of the delivered depth image: the pixels a cropping sensor node
  /// sends (depthCropRect). Depth beyond the cut-out (occlusion, seen-through pixels) is read
  /// only there, so that full and cropped depth give the same poses. Empty without boxes.
  std::array<int, 4> crop{{0, 0, 0, 0}};
};

/// Builds a CycleCamera from one input; throws InputError naming the camera and the field.
/// `correction` (the camera's depth calibration) applies to every depth read from its image.
CycleCamera makeCycleCamera(const SensorFrameData& frame, const Eigen::Isometry3d& T_world_depth,
                            const Eigen::Isometry3d& T_color_depth, float min_confidence,
                            const DepthCorrection& correction = DepthCorrection());

/// The depth-pixel rectangle [u0, u1) x [v0, v1) (delivered depth image) that can register into
/// colour box `box` grown by margin_px for depths in [min_range, max_range]: the box's corner
/// rays at both ranges projected into the depth image. False when it misses the image.
bool depthRectOfBox(const CycleCamera& cam, const DetectionBox& box, double margin_px,
                    double min_range, double max_range, std::array<int, 4>* rect);

/// With noise.amplitude_model and a frame that carries its amplitude: cam->image, within
/// cam->crop, replaced by the depth with each pixel's weak-return bias taken out (the Kinect
/// v2's, fitted on the real sensor: kinect_v2::weakReturnBias of the pixel's amplitude, less
/// the bias at profile_fit.bias_reference). Every stage that reads the camera's depth (the
/// cut-out, the carving's occlusion test, the seen-through pixels) then reads the same depth.
/// A pixel without an amplitude value (0) is kept as read. Otherwise nothing changes.
void correctWeakReturns(CycleCamera* cam, const EstimatorConfig& config);

/// Per-camera cut-out: every valid depth pixel in the frustum of a box whose registration into
/// the colour image falls inside that box (grown by cfg.box_margin_px), to world, inside the work
/// zone. Each pixel is emitted at most once per label (duplicate boxes). Appends to out[label].
void cutOutCamera(const CycleCamera& cam, uint16_t camera_index, const EstimatorConfig& config,
                  std::array<std::vector<CloudPoint>, kNumEnds>* out);


/// Depth noise std [m] at depth z [m] (config.noise).
float depthSigma(const EstimatorConfig::Noise& noise, double z);


/// The depth noise's growth [m] toward grazing incidence (the Kinect v2 model's incidence term,
/// Fankhauser et al. 2015): coefficient_mm x range^1.5 x (theta / (pi/2 - theta))^2 mm, theta
/// the angle between the ray and the surface normal, at most 84 deg. Added to depthSigma where
/// the surface is known (profile_fit.incidence_noise).
double incidenceSigma(double coefficient_mm, double range, double cos_incidence);

}  // namespace drill_pipe_pose
