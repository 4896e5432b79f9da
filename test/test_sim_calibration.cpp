// The simulator's calibration target: the scene file's entry, its validation, the HD colour
// camera, and the rendered board found where the truth puts it.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <string>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::sim;

namespace {

const std::string kSource = DRILL_PIPE_POSE_SOURCE_DIR;

const char* kScene = R"(
name: t
work_zone: {min: [3.7, 5.05, 0.0], max: [5.7, 7.05, 2.5]}
room: {size: [10.0, 10.0, 5.5], floor: concrete, walls: wall_paint}
calibration_target:
  type: charuco
  squares: [5, 5]
  square_length: 0.24
  marker_length: 0.18
  hold_s: 2.0
  move_s: 1.0
  placements:
    - {translation: [4.7, 6.05, 0.005], rpy_deg: [0, 0, 0]}
    - {translation: [4.7, 6.05, 1.0], rpy_deg: [30, 0, 0]}
)";

void expectError(const std::string& from, const std::string& to, const std::string& field) {
  std::string text = kScene;
  text.replace(text.find(from), from.size(), to);
  try {
    parseSceneConfig(text, "t.yaml");
    ADD_FAILURE() << "no error for " << to;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(SimCalibration, SceneEntryAndItsErrors) {
  const SceneConfig cfg = parseSceneConfig(kScene, "t.yaml");
  ASSERT_TRUE(cfg.calibration_target);
  EXPECT_EQ(cfg.calibration_target->placements.size(), 2u);
  EXPECT_DOUBLE_EQ(cfg.calibration_target->holdMiddle(1), 4.0);
  expectError("hold_s: 2.0", "hold_s: 0", "calibration_target.hold_s = 0");
  expectError("move_s: 1.0", "move_s: -1", "calibration_target.move_s = -1");
  expectError("marker_length: 0.18", "marker_length: 0.3", "marker_length = 0.3");
  expectError("type: charuco", "type: circles", "calibration_target.type");
  expectError("squares: [5, 5]", "squares: [5.5, 5]", "calibration_target: squares");
  expectError("hold_s: 2.0", "hold_s: 2.0\n  colour: red", "unknown key \"colour\"");
}

TEST(SimCalibration, KeyPosesHoldThenMove) {
  const SceneConfig cfg = parseSceneConfig(kScene, "t.yaml");
  const Scene scene = buildScene(cfg, sensorProfile("ideal"), 1);
  const size_t board = scene.objects.size() - 1;
  ASSERT_EQ(scene.objects[board].name, "calibration_target");
  EXPECT_NEAR(scene.objectPose(board, 1.9).translation().z(), 0.0025, 1e-9);  // held
  EXPECT_NEAR(scene.objectPose(board, 2.5).translation().z(), 0.5025, 0.01);  // half way
  EXPECT_NEAR(scene.objectPose(board, 10.0).translation().z(), 1.0 - 0.0025 * std::cos(M_PI / 6),
              1e-6);  // the last one held for ever
}

TEST(SimCalibration, HdColourFindsTheBoardWhereTheTruthIs) {
  SimulatorOptions opt;
  opt.color = true;
  opt.color_scale = 2;
  opt.simulated_detection = false;
  opt.seed = 1;
  RigSimulator sim(loadRigCalibration(kSource + "/config/rigs/thesis_lab.yaml"),
                   parseSceneConfig(kScene, "t.yaml"), opt);
  const CameraInfoData& info = sim.colorInfo(0);
  EXPECT_EQ(info.width, 1920u);
  EXPECT_EQ(info.height, 1080u);
  EXPECT_DOUBLE_EQ(info.K[0], 1081.4);
  EXPECT_DOUBLE_EQ(info.K[2], 959.5);
  EXPECT_DOUBLE_EQ(info.K[5], 539.5);
  const auto frame = sim.render(5, 1.0, 0);  // cam6, placement 0 (flat on the floor)
  cv::Mat gray;
  cv::cvtColor(cv::Mat(1080, 1920, CV_8UC3, const_cast<uint8_t*>(frame.bgr.data())), gray,
               cv::COLOR_BGR2GRAY);
  const calibration::TargetGeometry target;
  const auto found = calibration::detectTarget(target, gray);
  EXPECT_EQ(found.size(), 16u);
  const auto corners = calibration::targetCorners(target);
  const Eigen::Isometry3d T_cam_target = sim.trueT_world_link(5).inverse() *
                                         Eigen::Translation3d(4.7, 6.05, 0.005);
  const CameraInfoData& k = sim.colorInfo(5);
  for (const auto& c : found) {
    const Eigen::Vector3d p = T_cam_target * corners[c.id];
    const Eigen::Vector2d uv(k.K[0] * p.x() / p.z() + k.K[2], k.K[4] * p.y() / p.z() + k.K[5]);
    EXPECT_LT((c.uv - uv).norm(), 0.5) << "seed 1, corner " << c.id;
  }
}
