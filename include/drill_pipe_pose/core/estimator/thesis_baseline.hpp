#pragma once
// The thesis's chapter 3.4 pipeline (the UiA master's thesis on drill pipe-end pose estimation
// with six Kinect v2 sensor nodes) on the shared front end, for
// side-by-side comparison. Faithful, not improved:
//  - cut-out: the colour box mapped to depth pixels by scaling about the principal points (the
//    thesis's empirical mapping; no depth-to-colour registration), every valid depth pixel in it;
//  - `layers` (3) cycles of clouds concatenated per end;
//  - segmentation: the centroid (x, y) of the points between band_min_z and band_max_z world
//    height (pipes assumed standing on the ground), a square_size (0.2 m) square around it;
//  - models (uniformly sampled model surfaces) loaded at the origin, pre-aligned by translation to
//    the segmented cloud's centroid when further than prealign_distance, then PCL ICP with
//    icp_iterations (200) maximum iterations run icp_runs (10) times.
// PCL lives only in the .cpp.

#include <memory>
#include <vector>

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"
#include "drill_pipe_pose/core/estimator/stages.hpp"

namespace drill_pipe_pose {

class ThesisBaseline {
 public:
  explicit ThesisBaseline(const EstimatorConfig& config);
  ~ThesisBaseline();
  /// One cycle on validated cameras: fills result->ends, timing and debug clouds.
  void process(const std::vector<CycleCamera>& cameras, CycleResult* result);
  /// Forgets the layers and the models' last poses.
  void reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace drill_pipe_pose
