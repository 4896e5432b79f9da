#pragma once
// SIMULATED detector: what a trained 2D detector on the sensor node would output, derived from
// ground truth. Boxes come from the projected VISIBLE silhouette (occlusion considered, ray cast
// in the colour camera) of each tool-joint region (end face / pin nose to the end of the
// elevator taper), then degraded with the error model below. Deterministic per seed.

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"
#include "drill_pipe_pose/sim/scene.hpp"

namespace drill_pipe_pose::sim {

/// Error model of the simulated detector. Defaults (docs/conventions.md, "Sensor profiles"):
/// 3 px edge jitter, 10 % misses, 2 % box/pin swaps, 5 % duplicates, 2 % false positives.
struct DetectorErrorModel {
  double edge_jitter_px = 3.0;               ///< [px] sigma of each box edge
  double miss_probability = 0.10;            ///< per camera frame and end
  double swap_probability = 0.02;            ///< box_end <-> pin_end label swap
  double duplicate_probability = 0.05;       ///< extra, lower-confidence box on the same end
  double false_positive_probability = 0.02;  ///< per camera frame: a box on nothing
  int min_visible_pixels = 12;  ///< fewer visible colour pixels of the region: not detected
  int pixel_step = 1;           ///< ray-cast every n-th colour pixel of the region's bounds
};

/// One end's exact visible silhouette box (before errors), for tests and tools.
struct VisibleRegion {
  size_t end = 0;  ///< index into Scene::ends
  int visible_pixels = 0;
  float x_min = 0, y_min = 0, x_max = 0, y_max = 0;  ///< [px] full colour image
};

class SimulatedDetector {
 public:
  SimulatedDetector() = default;
  explicit SimulatedDetector(const DetectorErrorModel& model) : model_(model) {}

  /// Exact visible bounds of every end's region in the colour image of a camera at
  /// T_world_color (TRUE pose), scene at `snap`. Ends with too few visible pixels are omitted.
  std::vector<VisibleRegion> visibleRegions(const Scene& scene, const SceneSnapshot& snap,
                                            const PinholeCamera& color,
                                            const Eigen::Isometry3d& T_world_color) const;

  /// Detections with the error model applied; deterministic for (seed, camera, frame_index).
  std::vector<DetectionBox> detect(const Scene& scene, const SceneSnapshot& snap,
                                   const PinholeCamera& color,
                                   const Eigen::Isometry3d& T_world_color, uint64_t seed,
                                   uint64_t camera, uint64_t frame_index) const;

  const DetectorErrorModel& model() const { return model_; }

 private:
  DetectorErrorModel model_;
};

}  // namespace drill_pipe_pose::sim
