// Still frames and placements from a recording's frames (core/calibration/placements.hpp): two
// cameras at 2 frames/s with different phases, a board held 1.5 s and moved 0.5 s between
// placements (test/data/calibration_short.yaml's timing). No randomness.
#include <gtest/gtest.h>

#include "drill_pipe_pose/core/calibration/placements.hpp"

using namespace drill_pipe_pose::calibration;

namespace {

constexpr double kPeriod = 0.5, kHold = 1.5, kMove = 0.5;

/// A frame of `camera` at time t: 8 corners whose positions follow the board (placement k held
/// at offset 100 k px, moving linearly to the next), plus `jitter` px.
Observation frame(const std::string& camera, double t, double jitter = 0.0) {
  const double cycle = kHold + kMove;
  const int k = static_cast<int>(t / cycle);
  const double s = t - k * cycle;
  const double offset = 100.0 * (k + (s > kHold ? (s - kHold) / kMove : 0.0));
  Observation o;
  o.camera = camera;
  o.stamp = t;
  for (int id = 0; id < 8; ++id)
    o.corners.push_back({id, Eigen::Vector2d(offset + 40 * id + jitter, 300 + jitter)});
  return o;
}

/// Both cameras over `placements` holds: cam_a at phase 0.05 s, cam_b at 0.3 s.
std::vector<Observation> recording(int placements) {
  std::vector<Observation> frames;
  const double end = placements * (kHold + kMove) - kMove;
  for (double t = 0.05; t < end; t += kPeriod) frames.push_back(frame("cam_a", t));
  for (double t = 0.3; t < end; t += kPeriod) frames.push_back(frame("cam_b", t, 0.1));
  return frames;
}

}  // namespace

TEST(CalibrationPlacements, GroupsStillFramesOfBothCamerasIntoPlacements) {
  const std::vector<Observation> frames = recording(4);
  const PlacementGroups g = groupPlacements(frames);
  EXPECT_NEAR(g.frame_period, kPeriod, 1e-9);
  EXPECT_EQ(g.count, 4);
  // Every still frame lies inside its placement's hold; frames in a move are never still.
  for (size_t i = 0; i < frames.size(); ++i) {
    const double t = frames[i].stamp;
    const int k = static_cast<int>(t / (kHold + kMove));
    const bool in_hold = t - k * (kHold + kMove) < kHold;
    if (g.placement[i] >= 0) {
      EXPECT_TRUE(in_hold) << frames[i].camera << " at " << t;
      EXPECT_EQ(g.placement[i], k) << frames[i].camera << " at " << t;
    }
  }
  const std::vector<Observation> obs = selectObservations(frames, g);
  ASSERT_EQ(obs.size(), 8u);  // both cameras at all 4 placements
  for (size_t i = 0; i < obs.size(); ++i) EXPECT_EQ(obs[i].placement, static_cast<int>(i / 2));
  // The earliest still frame of a placement: cam_a's at 0.55 s in the first hold.
  EXPECT_NEAR(obs[0].stamp, 0.55, 1e-9);
}

TEST(CalibrationPlacements, MovingCornersLostCornersAndOrderDoNotMatter) {
  std::vector<Observation> frames = recording(3);
  // A corner moving 0.6 px in cam_a's third frame of the first hold: that frame and the next
  // are not still (each differs from its predecessor).
  frames[2].corners[3].uv.x() += 0.6;
  // cam_b's second frame loses a corner: it and the next frame are not still.
  frames[frames.size() / 2 + 1].corners.pop_back();
  std::reverse(frames.begin(), frames.end());  // any input order
  const PlacementGroups g = groupPlacements(frames);
  EXPECT_EQ(g.count, 3);
  for (size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].camera == "cam_a" && std::abs(frames[i].stamp - 1.05) < 1e-9) {
      EXPECT_EQ(g.placement[i], -1);
    }
  }
  PlacementOptions coarse;
  coarse.max_corner_motion_px = 1.0;
  EXPECT_EQ(groupPlacements(frames, coarse).count, 3);
}

TEST(CalibrationPlacements, NoStillFrameNoPlacement) {
  std::vector<Observation> frames;
  for (int i = 0; i < 6; ++i) {
    Observation o = frame("cam_a", 0.05 + i * kPeriod, 5.0 * i);  // moves 5 px per frame
    frames.push_back(o);
  }
  const PlacementGroups g = groupPlacements(frames);
  EXPECT_EQ(g.count, 0);
  EXPECT_TRUE(selectObservations(frames, g).empty());
  EXPECT_EQ(groupPlacements({}).count, 0);
}
