#pragma once
// From a recording's frames to placements: which frames show the target held still, and which
// still frames belong to the same placement. ROS-free; the bag reader (calibrate_rig --bag) feeds
// it one Observation per recorded frame (extractObservation, `placement` unset) in any order.
//
// A frame is still when the target's corners agree with the same camera's previous frame (at
// least 6 shared ids, three quarters of either frame's, every shared corner within
// `max_corner_motion_px`: a board seen in part may gain or lose a corner between frames): frames taken while the board moves, and the
// first frame after a move, are skipped. The still frames of all cameras, in time order, form
// one placement as long as no gap between consecutive still frames is longer than
// `gap_frame_periods` frame periods; a longer gap (the board was carried) starts the next one.
// Placements are numbered from 0 in time order, so placement 0 is the first still placement
// (the calibration anchor: the board lying on the floor mark).

#include <vector>

#include "drill_pipe_pose/core/calibration/observations.hpp"

namespace drill_pipe_pose::calibration {

struct PlacementOptions {
  /// [px] a corner that moved more than this since the camera's previous frame means the board
  /// moved. 0.5 px: the simulator's still HD frames agree within 0.1 px (sensor noise), while a
  /// board carried at a walking pace moves tens of pixels between frames at 2 Hz.
  double max_corner_motion_px = 0.5;
  /// A gap of more than this many frame periods without a still frame in any camera starts a
  /// new placement. 1.5: within a hold every camera gives a still frame each period, while a
  /// move of at least one period plus the first frame after it (not still: it differs from the
  /// frame taken during the move) leave a gap of at least 2 periods; chosen on
  /// test/data/calibration_short.yaml (hold 1.5 s, move 0.5 s, 2 frames/s).
  double gap_frame_periods = 1.5;
  /// [s] the recording's frame period per camera; 0: the median interval between a camera's
  /// consecutive frames over all cameras.
  double frame_period = 0.0;
};

struct PlacementGroups {
  /// Per input frame: its placement index, or -1 (no target, moving, or the first frame).
  std::vector<int> placement;
  int count = 0;              ///< placements found
  double frame_period = 0.0;  ///< [s] the period used
};

/// Groups `frames` (one per recorded frame; `camera`, `stamp` and `corners` used) into
/// placements. Frames without corners count as frames (a camera that lost the target is not
/// still at its next frame).
PlacementGroups groupPlacements(const std::vector<Observation>& frames,
                                const PlacementOptions& options = {});

/// Up to `max_frames` observations per camera and placement, with `placement` set: of that
/// camera's still frames in the placement, those with the most corners (the earliest among
/// equals); each is a measurement of the same target pose with its own noise, so the solver
/// averages them. In the order of placement, then of `frames`.
std::vector<Observation> selectObservations(const std::vector<Observation>& frames,
                                            const PlacementGroups& groups, int max_frames = 1);

}  // namespace drill_pipe_pose::calibration
