// Rig calibration files: valid files load and round-trip; malformed ones are named precisely.
#include <gtest/gtest.h>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"

using namespace drill_pipe_pose;

namespace {

const char* kValid = R"(
world_frame: world
cameras:
  - name: cam1
    translation: [4.7, 0.2, 5.0]
    rotation: [0.0, 0.0, 0.0, 1.0]
  - name: cam2
    translation: [0.2, 5.0, 5.0]
    rotation: [0.7071068, 0.0, 0.0, 0.7071068]
)";

void expectRejected(const std::string& yaml, std::initializer_list<const char*> needles) {
  try {
    parseRigCalibration(yaml, "rig.yaml");
    FAIL() << "accepted:\n" << yaml;
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("rig.yaml"), std::string::npos) << msg;
    for (const char* n : needles) EXPECT_NE(msg.find(n), std::string::npos) << msg;
  }
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  s.replace(s.find(from), from.size(), to);
  return s;
}

}  // namespace

TEST(RigCalibration, LoadsAndRoundTrips) {
  const RigCalibration rig = parseRigCalibration(kValid, "rig.yaml");
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.find("cam2"), 1);
  EXPECT_EQ(rig.find("cam9"), -1);
  EXPECT_TRUE(rig.cameras[0].T_world_link.translation().isApprox(Eigen::Vector3d(4.7, 0.2, 5.0)));
  const Eigen::Vector3d y = rig.cameras[1].T_world_link.linear() * Eigen::Vector3d::UnitY();
  EXPECT_TRUE(y.isApprox(Eigen::Vector3d::UnitZ(), 1e-6));  // 90 deg about x
  const RigCalibration back = parseRigCalibration(rigCalibrationToYaml(rig), "again");
  ASSERT_EQ(back.cameras.size(), 2u);
  EXPECT_TRUE(back.cameras[1].T_world_link.isApprox(rig.cameras[1].T_world_link, 1e-12));
  // Without depth keys: no depth correction, and none written back.
  EXPECT_EQ(rig.cameras[0].depth_offset, 0.0);
  EXPECT_EQ(rig.cameras[0].depth_scale, 1.0);
  EXPECT_EQ(rigCalibrationToYaml(rig).find("depth_"), std::string::npos);
}

TEST(RigCalibration, DepthOffsetAndScaleLoadAndRoundTrip) {
  const std::string text =
      replace(kValid, "    rotation: [0.0, 0.0, 0.0, 1.0]\n",
              "    rotation: [0.0, 0.0, 0.0, 1.0]\n    depth_offset: -0.0255\n"
              "    depth_scale: 1.019\n");
  const RigCalibration rig = parseRigCalibration(text, "rig.yaml");
  EXPECT_DOUBLE_EQ(rig.cameras[0].depth_offset, -0.0255);
  EXPECT_DOUBLE_EQ(rig.cameras[0].depth_scale, 1.019);
  EXPECT_EQ(rig.cameras[1].depth_offset, 0.0);  // cam2 has none
  EXPECT_EQ(rig.cameras[1].depth_scale, 1.0);
  const RigCalibration back = parseRigCalibration(rigCalibrationToYaml(rig), "again");
  EXPECT_EQ(back.cameras[0].depth_offset, rig.cameras[0].depth_offset);  // 17 digits: exact
  EXPECT_EQ(back.cameras[0].depth_scale, rig.cameras[0].depth_scale);
  EXPECT_EQ(back.cameras[1].depth_offset, 0.0);
  EXPECT_EQ(back.cameras[1].depth_scale, 1.0);
}

TEST(RigCalibration, WeakReturnBiasLoadsRoundTripsAndIsBounded) {
  const std::string text =
      replace(kValid, "    rotation: [0.0, 0.0, 0.0, 1.0]\n",
              "    rotation: [0.0, 0.0, 0.0, 1.0]\n    weak_return_bias: 5.25e-9\n");
  const RigCalibration rig = parseRigCalibration(text, "rig.yaml");
  ASSERT_TRUE(rig.cameras[0].weak_return_bias.has_value());
  EXPECT_DOUBLE_EQ(*rig.cameras[0].weak_return_bias, 5.25e-9);
  EXPECT_FALSE(rig.cameras[1].weak_return_bias.has_value());  // cam2: the sensor's law
  const RigCalibration back = parseRigCalibration(rigCalibrationToYaml(rig), "again");
  EXPECT_EQ(back.cameras[0].weak_return_bias, rig.cameras[0].weak_return_bias);
  EXPECT_FALSE(back.cameras[1].weak_return_bias.has_value());
  const auto with = [](const std::string& line) {
    return replace(kValid, "    translation: [0.2, 5.0, 5.0]\n",
                   "    translation: [0.2, 5.0, 5.0]\n" + line);
  };
  expectRejected(with("    weak_return_bias: 4.0\n"),
                 {"camera 'cam2'", "weak_return_bias", "outside [0, 4e-08]"});
  expectRejected(with("    weak_return_bias: -1e-9\n"), {"camera 'cam2'", "weak_return_bias"});
  expectRejected(with("    weak_return_bias: big\n"),
                 {"camera 'cam2'", "weak_return_bias", "not a number"});
}

TEST(RigCalibrationBadInput, NonUnitQuaternionNamesCameraAndField) {
  expectRejected(replace(kValid, "[0.7071068, 0.0, 0.0, 0.7071068]", "[0.5, 0.0, 0.0, 0.5]"),
                 {"camera 'cam2'", "rotation", "norm 0.707"});
}

TEST(RigCalibrationBadInput, NonFiniteAndWrongLength) {
  expectRejected(replace(kValid, "[4.7, 0.2, 5.0]", "[4.7, .nan, 5.0]"),
                 {"camera 'cam1'", "translation[1]", "not finite"});
  expectRejected(replace(kValid, "[4.7, 0.2, 5.0]", "[4.7, 0.2]"),
                 {"camera 'cam1'", "translation", "3 numbers", "2 elements"});
  expectRejected(replace(kValid, "[4.7, 0.2, 5.0]", "[4.7, abc, 5.0]"),
                 {"camera 'cam1'", "translation[1] = 'abc'"});
}

TEST(RigCalibrationBadInput, DepthCalibrationOutOfRangeOrNotANumber) {
  const auto with = [](const std::string& lines) {
    return replace(kValid, "    translation: [0.2, 5.0, 5.0]\n",
                   "    translation: [0.2, 5.0, 5.0]\n" + lines);
  };
  expectRejected(with("    depth_offset: 25.5\n"),
                 {"camera 'cam2'", "depth_offset", "25.5", "outside [-0.2, 0.2]"});
  expectRejected(with("    depth_offset: -0.21\n"), {"camera 'cam2'", "depth_offset", "outside"});
  expectRejected(with("    depth_offset: .nan\n"), {"camera 'cam2'", "depth_offset", "not finite"});
  expectRejected(with("    depth_offset: 3mm\n"),
                 {"camera 'cam2'", "depth_offset", "'3mm' is not a number"});
  expectRejected(with("    depth_scale: 1.2\n"),
                 {"camera 'cam2'", "depth_scale", "1.2", "outside [0.9, 1.1]"});
  expectRejected(with("    depth_scale: 0\n"), {"camera 'cam2'", "depth_scale", "outside"});
  expectRejected(with("    depth_scale: .inf\n"), {"camera 'cam2'", "depth_scale", "not finite"});
  expectRejected(with("    depth_scale: [1.0]\n"),
                 {"camera 'cam2'", "depth_scale", "not a number"});
}

TEST(RigCalibrationBadInput, DuplicateUnknownAndMissing) {
  expectRejected(replace(kValid, "name: cam2", "name: cam1"), {"camera 'cam1'", "duplicate"});
  expectRejected(replace(kValid, "    rotation: [0.0, 0.0, 0.0, 1.0]",
                         "    rotation: [0.0, 0.0, 0.0, 1.0]\n    rotaton: [1, 2]"),
                 {"camera 'cam1'", "unknown field 'rotaton'"});
  expectRejected(replace(kValid, "    translation: [0.2, 5.0, 5.0]\n", ""),
                 {"camera 'cam2'", "translation is missing"});
  expectRejected("cameras: []", {"non-empty"});
  expectRejected("cameras: [", {"not valid YAML"});
  EXPECT_THROW(loadRigCalibration("/nonexistent/rig.yaml"), InputError);
}

// Found by test/fuzz/fuzz_rig_yaml (test/fuzz/regressions/rig_yaml/): a file of the wrong shape
// threw yaml-cpp's exception instead of an InputError; a world frame or sensor name with control
// characters or broken UTF-8 was accepted and written back unquoted (no round trip).
TEST(RigCalibrationBadInput, WrongShapesAndNames) {
  expectRejected(replace(kValid, "world_frame: world", "world_frame: [a, b]"),
                 {"world_frame", "must be a string"});
  expectRejected(replace(kValid, "world_frame: world", "world_frame: \"w\\x01rld\""),
                 {"world_frame", "must match"});
  expectRejected(replace(kValid, "world_frame: world", "world_frame: \"a: b\""),
                 {"world_frame", "must match"});
  expectRejected(replace(kValid, "name: cam2", "name: {a: 1}"), {"cameras[1]: name"});
  expectRejected(replace(kValid, "    rotation: [0.0, 0.0, 0.0, 1.0]",
                         "    rotation: [0.0, 0.0, 0.0, 1.0]\n    sensor: \"kin ect\""),
                 {"camera 'cam1' sensor", "must match"});
  expectRejected(std::string("[a, b]: 1\n") + kValid, {"rig.yaml"});
  // Names of the allowed characters load and round-trip.
  const RigCalibration rig = parseRigCalibration(
      replace(replace(kValid, "world_frame: world", "world_frame: rig/world_2.0-a"),
              "    rotation: [0.0, 0.0, 0.0, 1.0]",
              "    rotation: [0.0, 0.0, 0.0, 1.0]\n    sensor: kinect_v2.lab-1"),
      "rig.yaml");
  const RigCalibration back = parseRigCalibration(rigCalibrationToYaml(rig), "again");
  EXPECT_EQ(back.world_frame, "rig/world_2.0-a");
  EXPECT_EQ(back.cameras[0].sensor, "kinect_v2.lab-1");
}
