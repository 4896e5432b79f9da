// The cycle runner shared by the node and bench_estimator: input assembly from frames plus a
// transform source, problems named per camera, the output policy (a pose repeated for at most
// max_pose_age), and the reset when time jumps back. Simulator frames, fixed seed 23.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <random>
#include <stdexcept>

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/cycle_runner.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/track.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

using namespace drill_pipe_pose;

namespace {

constexpr uint32_t kSeed = 23;  // listed in docs/seeds.md

/// The simulator's published transforms as a TransformSource.
class SimTransforms : public TransformSource {
 public:
  explicit SimTransforms(const sim::RigSimulator& s) {
    for (size_t i = 0; i < s.numCameras(); ++i) {
      const std::string& cam = s.cameraName(i);
      const Eigen::Isometry3d T_world_depth = s.publishedT_world_link(i) * s.T_link_depth(i);
      known_[{"world", conventions::depthOpticalFrame(cam)}] = T_world_depth;
      known_[{conventions::colorOpticalFrame(cam), conventions::depthOpticalFrame(cam)}] =
          s.T_link_depth(i);
    }
  }
  Eigen::Isometry3d lookup(const std::string& target, const std::string& source,
                           int64_t) override {
    auto it = known_.find({target, source});
    if (it == known_.end()) throw std::runtime_error("no transform " + target + " <- " + source);
    return it->second;
  }

 private:
  std::map<std::pair<std::string, std::string>, Eigen::Isometry3d> known_;
};

std::unique_ptr<sim::RigSimulator> simulator() {
  const std::string dir = DRILL_PIPE_POSE_SOURCE_DIR;
  sim::SimulatorOptions opt;
  opt.profile = "kinect_v2_calibrated";
  opt.seed = kSeed;
  opt.sensor_config_dir = dir + "/config/sensors";
  opt.stamp_origin_ns = 1000000000;
  return sim::loadScenario(dir + "/config/rigs/thesis_lab.yaml",
                           dir + "/config/scenes/thesis_vertical.yaml", opt);
}

struct Fixture {
  std::unique_ptr<sim::RigSimulator> sim = simulator();
  SimTransforms tf{*sim};
  EstimatorNodeConfig config() const {
    EstimatorNodeConfig c;
    for (size_t i = 0; i < sim->numCameras(); ++i) c.cameras.push_back(sim->cameraName(i));
    c.estimator.work_zone.min = sim->workZone().min;
    c.estimator.work_zone.max = sim->workZone().max;
    return c;
  }
  /// Adds cycle k's frames (boxes removed when `blind`) and polls once every frame is in.
  std::vector<CycleOutput> feed(CycleRunner& runner, int k, bool blind = false) {
    for (size_t i = 0; i < sim->numCameras(); ++i) {
      SensorFrameData f = sim->render(i, sim->captureTime(i, k), k).sensor_frame;
      if (blind) f.boxes.clear();
      const double arrival = f.stamp_ns * 1e-9 + 0.01;
      runner.add(sim->cameraName(i), f.stamp_ns, arrival, [f] { return f; });
    }
    return runner.poll(sim->captureTime(0, k) + 0.02);
  }
};

}  // namespace

TEST(CycleRunner, RepeatsTheLastPoseForAtMostMaxPoseAge) {
  Fixture fx;
  EstimatorNodeConfig rc = fx.config();
  rc.max_pose_age = 0.1;  // three 30 Hz cycles
  CycleRunner runner(rc, &fx.tf);
  std::vector<CycleOutput> outs;
  for (int k = 0; k < 10; ++k)
    for (auto& o : fx.feed(runner, k)) outs.push_back(std::move(o));
  for (int k = 10; k < 16; ++k)
    for (auto& o : fx.feed(runner, k, true)) outs.push_back(std::move(o));
  for (auto& o : runner.poll(1e12)) outs.push_back(std::move(o));
  ASSERT_GE(outs.size(), 15u) << "seed " << kSeed;
  // The last sighted cycle: a fresh pose.
  int last_fresh = -1;
  for (size_t c = 0; c < outs.size(); ++c)
    if (outs[c].ends[0].fresh) last_fresh = static_cast<int>(c);
  ASSERT_GE(last_fresh, 5) << "no fresh box-end pose (seed " << kSeed << ")";
  const CycleOutput& seen = outs[static_cast<size_t>(last_fresh)];
  for (size_t c = static_cast<size_t>(last_fresh) + 1; c < outs.size(); ++c) {
    const PublishedEnd& p = outs[c].ends[0];
    EXPECT_FALSE(p.fresh);
    const double age = (outs[c].cycle.stamp_ns - seen.cycle.stamp_ns) * 1e-9;
    EXPECT_NEAR(p.age, age, 1e-9);
    EXPECT_EQ(p.valid, age <= rc.max_pose_age) << "cycle " << c << " age " << age;
    if (p.valid) {
      EXPECT_TRUE(p.estimate.T_world_end.isApprox(seen.ends[0].estimate.T_world_end));
      EXPECT_NE(p.message.find("last pose repeated"), std::string::npos) << p.message;
    } else {
      EXPECT_NE(p.message.find("last pose too old"), std::string::npos) << p.message;
    }
  }
  EXPECT_FALSE(outs.back().ends[0].valid);
}

TEST(CycleRunner, NamesTheCameraOfABadFrameAndOfAMissingTransform) {
  Fixture fx;
  CycleRunner runner(fx.config(), &fx.tf);
  const std::string bad = fx.sim->cameraName(0), lost = fx.sim->cameraName(1);
  for (size_t i = 0; i < fx.sim->numCameras(); ++i) {
    SensorFrameData f = fx.sim->render(i, fx.sim->captureTime(i, 0), 0).sensor_frame;
    if (fx.sim->cameraName(i) == lost) f.depth_frame_id = "nowhere";
    const std::string cam = fx.sim->cameraName(i);
    FrameLoader load = [f] { return f; };
    if (cam == bad) load = []() -> SensorFrameData { fail("cam_x depth: 16UC3 is not a depth encoding"); };
    runner.add(cam, f.stamp_ns, f.stamp_ns * 1e-9, load);
  }
  const auto outs = runner.poll(1e12);
  ASSERT_EQ(outs.size(), 1u);
  ASSERT_EQ(outs[0].problems.size(), 2u);
  std::map<std::string, InputProblem> by_camera;
  for (const auto& p : outs[0].problems) by_camera[p.camera] = p;
  EXPECT_EQ(by_camera.at(bad).kind, InputProblem::Kind::kBadInput);
  EXPECT_NE(by_camera.at(bad).message.find("16UC3"), std::string::npos);
  EXPECT_EQ(by_camera.at(lost).kind, InputProblem::Kind::kTransform);
  EXPECT_NE(by_camera.at(lost).message.find("nowhere"), std::string::npos)
      << by_camera.at(lost).message;
  EXPECT_EQ(outs[0].inputs.size(), fx.sim->numCameras() - 2);
}

// The node's `rig` parameter: each camera's depth calibration from the rig file goes into its
// input, by camera name; a camera the file lacks gets none and is listed (for one warning).
TEST(CycleRunner, TakesEachCamerasDepthCorrectionFromTheRigFile) {
  Fixture fx;
  RigCalibration rig = fx.sim->trueRig();
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    rig.cameras[i].depth_offset = 0.01 * static_cast<double>(i + 1);
    rig.cameras[i].depth_scale = 1.0 + 0.001 * static_cast<double>(i + 1);
  }
  const std::string missing = rig.cameras.back().name;
  rig.cameras.pop_back();
  const std::string path = testing::TempDir() + "cycle_runner_rig.yaml";
  {
    std::ofstream f(path);
    f << rigCalibrationToYaml(rig);
  }
  EstimatorNodeConfig rc = fx.config();
  rc.rig = path;
  CycleRunner runner(rc, &fx.tf);
  EXPECT_EQ(runner.camerasWithoutDepthCorrection(), std::vector<std::string>{missing});
  EXPECT_EQ(runner.depthCorrections().size(), rig.cameras.size());
  const auto outs = fx.feed(runner, 0);
  ASSERT_EQ(outs.size(), 1u);
  ASSERT_EQ(outs[0].inputs.size(), fx.sim->numCameras());
  for (const CameraInput& in : outs[0].inputs) {
    SCOPED_TRACE(in.frame.camera);
    const int i = rig.find(in.frame.camera);
    if (i < 0) {
      EXPECT_TRUE(in.depth_correction.isNone());
      continue;
    }
    EXPECT_EQ(in.depth_correction.offset, rig.cameras[i].depth_offset);
    EXPECT_EQ(in.depth_correction.scale, rig.cameras[i].depth_scale);
  }
  // A bad rig file stops the runner, naming the file.
  rc.rig = "/nonexistent/rig.yaml";
  try {
    CycleRunner bad(rc, &fx.tf);
    FAIL() << "accepted a missing rig file";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/rig.yaml"), std::string::npos) << e.what();
  }
}

TEST(CycleRunner, TimeJumpingBackResetsPosesAndBuffers) {
  Fixture fx;
  CycleRunner runner(fx.config(), &fx.tf);
  for (int k = 60; k < 66; ++k) fx.feed(runner, k);
  // A frame without boxes: without the reset, the last poses (of a later stamp) would repeat.
  SensorFrameData f = fx.sim->render(0, fx.sim->captureTime(0, 0), 0).sensor_frame;
  f.boxes.clear();
  const AddResult r = runner.add(fx.sim->cameraName(0), f.stamp_ns, 1e6, [f] { return f; });
  EXPECT_TRUE(r.time_jumped_back);
  EXPECT_GT(r.jump_s, 1.5);
  const auto outs = runner.poll(1e12);
  ASSERT_EQ(outs.size(), 1u);
  for (const auto& e : outs[0].ends) {
    EXPECT_FALSE(e.valid) << e.message;
    EXPECT_EQ(e.message.find("last pose"), std::string::npos) << e.message;
  }
}

TEST(Track, ContinuesPredictsAndFollows) {
  Track t;
  EXPECT_FALSE(t.continues(1000, 0.5));
  EXPECT_FALSE(t.recent(1000, 0.5));
  TrackedFit f;
  f.origin = Eigen::Vector3d(1, 2, 3);
  t.follow(1000000000, f, 0.5, 0.05);
  EXPECT_TRUE(t.valid);
  EXPECT_EQ(t.cycles, 1);
  EXPECT_TRUE(t.velocity.isZero());
  f.origin = Eigen::Vector3d(1.01, 2, 3);
  t.follow(1100000000, f, 0.5, 0.05);  // 0.1 s later, 1 cm: 0.1 m/s
  EXPECT_NEAR(t.velocity.x(), 0.1, 1e-9);
  EXPECT_TRUE(t.continues(1200000000, 0.5));
  EXPECT_FALSE(t.continues(1100000000, 0.5)) << "a zero gap does not continue a track";
  EXPECT_FALSE(t.continues(1700000000, 0.5)) << "a gap over max_gap ends it";
  EXPECT_NEAR(t.predict(1200000000).x(), 1.02, 1e-9);
  EXPECT_NEAR(t.predict(2100000000, 0.005).x(), 1.015, 1e-9) << "clamped to max_prediction";
  f.origin = Eigen::Vector3d(2, 2, 3);  // a jump: the velocity restarts
  t.follow(1200000000, f, 0.5, 0.05);
  EXPECT_TRUE(t.velocity.isZero());
  t.end();
  EXPECT_FALSE(t.continues(1300000000, 0.5));
  EXPECT_TRUE(t.recent(1300000000, 0.5)) << "an ended track still tells its last fit";
}

TEST(Track, MeanVelocityTellsAMovingEndFromAStaticOnesNoise) {
  // A static end whose fit scatters by 2 mm along z between 30 Hz cycles (seeded), one of its
  // fits 4 cm off and back; and an end moving at 0.2 m/s along z whose fit fails in one cycle.
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.002);
  const int64_t period = 33333333;
  Track still, moving;
  TrackedFit f;
  double worst_still = 0;
  for (int k = 0; k < 100; ++k) {
    const int64_t t = 1000000000 + k * period;
    f.origin = Eigen::Vector3d(1, 2, 3 + noise(rng) + (k == 50 ? 0.04 : 0.0));
    still.follow(t, f, 0.5, 0.05);
    if (k > 20) worst_still = std::max(worst_still, still.mean_velocity.norm());
    if (k == 60) {
      moving.end();  // no fit this cycle: the mean velocity survives the gap
      continue;
    }
    f.origin = Eigen::Vector3d(1, 2, 3 - 0.2 * k * period * 1e-9 + noise(rng));
    moving.follow(t, f, 0.5, 0.05);
    if (k == 59) {
      EXPECT_NEAR(moving.mean_velocity.z(), -0.2, 0.05) << "seed 7, cycle " << k;
    }
  }
  EXPECT_LT(worst_still, 0.07) << "seed 7: a static end's mean speed, the wild fit included";
  EXPECT_NEAR(moving.mean_velocity.z(), -0.2, 0.05) << "seed 7, after the cycle without a fit";
  f.origin = Eigen::Vector3d(3, 2, 3);  // another end: the mean velocity restarts
  moving.follow(1000000000 + 100 * period, f, 0.5, 0.05);
  EXPECT_TRUE(moving.mean_velocity.isZero());
}
