// The calibration solver on synthetic observations: a rig of four cameras around a work zone,
// targets at known poses, corners with noise, depth samples with per-camera offsets. Seeds fixed
// (printed in failures through SCOPED_TRACE).
#include <gtest/gtest.h>

#include <random>

#include "drill_pipe_pose/core/calibration/solver.hpp"
#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/errors.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::calibration;

namespace {

Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

struct Synthetic {
  ObservationSet set;
  RigCalibration truth;
  std::vector<Eigen::Isometry3d> targets;
};

Intrinsics hd() {
  Intrinsics k;
  k.width = 1920, k.height = 1080, k.fx = k.fy = 1081.4, k.cx = 959.5, k.cy = 539.5;
  return k;
}

/// Four cameras 4.8 m up on the corners of a 10 m cell, aimed at its centre; `placements` target
/// poses near the centre, tilted towards random cameras.
Synthetic makeRig(uint32_t seed, int placements, double corner_noise_px, double depth_noise) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Synthetic s;
  s.set.target.type = TargetGeometry::Type::kCharuco;
  const Eigen::Vector3d centre(5, 5, 0.5);
  const std::vector<Eigen::Vector3d> eyes{{0.3, 0.3, 4.8}, {9.7, 0.3, 4.8}, {0.3, 9.7, 4.8},
                                          {9.7, 9.7, 4.8}};
  for (size_t c = 0; c < eyes.size(); ++c) {
    CameraSetup cam;
    cam.name = "cam" + std::to_string(c + 1);
    cam.intrinsics = hd();
    Intrinsics d;
    d.width = 512, d.height = 424, d.fx = d.fy = 365.0, d.cx = 255.5, d.cy = 211.5;
    cam.depth_intrinsics = d;
    cam.T_camera_depth.translation() = Eigen::Vector3d(-0.0515, 0, -0.001);
    s.set.cameras.push_back(cam);
    CameraCalibration cc;
    cc.name = cam.name;
    cc.T_world_link = lookAt(eyes[c], centre);
    cc.depth_offset = 0.02 * (2 * u01(rng) - 1);
    s.truth.cameras.push_back(cc);
  }
  const std::vector<Eigen::Vector3d> X = targetCorners(s.set.target);
  for (int p = 0; p < placements; ++p) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = centre + Eigen::Vector3d(1.5 * n01(rng), 1.5 * n01(rng), 0.8 * u01(rng));
    // Face up, tilted up to 35 deg towards a random direction; placement 0 flat (the anchor).
    const double tilt = p == 0 ? 0.0 : 0.6 * u01(rng);
    const double dir = 2 * M_PI * u01(rng);
    T.linear() = (Eigen::AngleAxisd(dir, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()) *
                  Eigen::AngleAxisd(u01(rng) * 2 * M_PI, Eigen::Vector3d::UnitZ()))
                     .toRotationMatrix();
    s.targets.push_back(T);
    for (size_t c = 0; c < s.truth.cameras.size(); ++c) {
      const Eigen::Isometry3d T_ct = s.truth.cameras[c].T_world_link.inverse() * T;
      if ((T_ct.linear() * Eigen::Vector3d::UnitZ()).z() > -0.3) continue;  // seen edge-on
      Observation o;
      o.camera = s.set.cameras[c].name;
      o.placement = p;
      const Intrinsics& k = s.set.cameras[c].intrinsics;
      for (size_t id = 0; id < X.size(); ++id) {
        const Eigen::Vector3d pc = T_ct * X[id];
        o.corners.push_back({static_cast<int>(id),
                             Eigen::Vector2d(k.fx * pc.x() / pc.z() + k.cx + corner_noise_px * n01(rng),
                                             k.fy * pc.y() / pc.z() + k.cy + corner_noise_px * n01(rng))});
      }
      // Depth samples on the target's inner 1 x 1 m.
      const Eigen::Isometry3d T_dt = s.set.cameras[c].T_camera_depth.inverse() * T_ct;
      const Intrinsics& d = *s.set.cameras[c].depth_intrinsics;
      for (int i = 0; i < 300; ++i) {
        const Eigen::Vector3d pd = T_dt * Eigen::Vector3d(u01(rng) - 0.5, u01(rng) - 0.5, 0.0);
        const double z = pd.z() + s.truth.cameras[c].depth_offset + depth_noise * n01(rng);
        o.depth.push_back({d.fx * pd.x() / pd.z() + d.cx, d.fy * pd.y() / pd.z() + d.cy, z});
      }
      s.set.observations.push_back(o);
    }
  }
  s.set.anchor.placement = 0;
  s.set.anchor.T_world_anchor = s.targets[0];
  return s;
}

}  // namespace

TEST(CalibrationSolver, RecoversExtrinsicsAndDepthOffsets) {
  for (uint32_t seed : {11u, 12u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Synthetic s = makeRig(seed, 30, 0.15, 0.008);
    const CalibrationResult r = calibrate(s.set);
    const RigComparison cmp = compareRigs(r.rig(s.set), s.truth);
    for (const auto& c : cmp.cameras) {
      SCOPED_TRACE(c.name);
      EXPECT_LT(c.translation_error, 0.002);
      EXPECT_LT(c.rotation_error, 0.05 * M_PI / 180);
      // 0.3-1.2 mm on these seeds: the distance of a 1.2 m target at 7 m from 0.15 px corners is
      // what limits it.
      EXPECT_LT(std::abs(c.depth_offset_error), 0.002);
    }
    // The anchoring (one placement flat on a mark) is reported apart.
    EXPECT_LT(cmp.anchor_translation, 0.006);
    EXPECT_LT(cmp.anchor_rotation, 0.1 * M_PI / 180);
    EXPECT_LT(r.corner_rms_px, 0.3);
    EXPECT_TRUE(r.rejected.empty());
  }
}

TEST(CalibrationSolver, RejectsAMovedTargetObservation) {
  Synthetic s = makeRig(13, 30, 0.15, 0.008);
  // The target moved during one frame of one camera: its corners are 20 px off in a shear.
  Observation& o = s.set.observations[7];
  for (size_t i = 0; i < o.corners.size(); ++i) o.corners[i].uv.x() += 20.0 * (i % 4) / 3.0;
  const CalibrationResult r = calibrate(s.set);
  ASSERT_EQ(r.rejected.size(), 1u);
  EXPECT_EQ(r.rejected[0].camera, o.camera);
  EXPECT_EQ(r.rejected[0].placement, o.placement);
  for (const auto& c : compareRigs(r.rig(s.set), s.truth).cameras)
    EXPECT_LT(c.translation_error, 0.002) << c.name;
}

TEST(CalibrationSolver, ReversesChessboardObservations) {
  Synthetic s = makeRig(14, 30, 0.15, 0.008);
  // The same corners read as a symmetric chessboard, with every third observation's order
  // reversed (what a chessboard detector may return).
  s.set.target.type = TargetGeometry::Type::kChessboard;
  const int n = static_cast<int>(targetCorners(s.set.target).size());
  int reversed = 0;
  // (Not the first: the first camera's view of the anchor placement defines a chessboard's
  // orientation.)
  for (size_t i = 1; i < s.set.observations.size(); i += 3, ++reversed)
    for (auto& c : s.set.observations[i].corners) c.id = n - 1 - c.id;
  const CalibrationResult r = calibrate(s.set);
  EXPECT_EQ(r.reversed_observations, reversed);
  EXPECT_TRUE(r.rejected.empty());
  for (const auto& c : compareRigs(r.rig(s.set), s.truth).cameras)
    EXPECT_LT(c.translation_error, 0.002) << c.name;
}

TEST(CalibrationSolver, RefusesACameraWithTooFewPlacements) {
  Synthetic s = makeRig(15, 30, 0.15, 0.008);
  std::vector<Observation> kept;
  int cam4 = 0;
  for (const auto& o : s.set.observations)
    if (o.camera != "cam4" || ++cam4 <= 2) kept.push_back(o);
  s.set.observations = kept;
  try {
    calibrate(s.set);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera cam4: saw the target in 2 usable placements"),
              std::string::npos)
        << e.what();
  }
}

TEST(CalibrationSolver, RefusesCamerasNotConnectedToTheAnchor) {
  Synthetic s = makeRig(16, 30, 0.15, 0.008);
  // cam3 and cam4 only ever see placements that cam1 and cam2 do not.
  std::vector<Observation> kept;
  for (const auto& o : s.set.observations) {
    const bool left = o.camera == "cam1" || o.camera == "cam2";
    if (left == (o.placement % 2 == 0)) kept.push_back(o);
  }
  s.set.observations = kept;
  try {
    calibrate(s.set);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras cam3, cam4 share no chain of placements"),
              std::string::npos)
        << e.what();
  }
}

TEST(CalibrationSolver, RefusesIntrinsicsThatDoNotMatchTheImages) {
  Synthetic s = makeRig(17, 30, 0.15, 0.008);
  s.set.cameras[2].intrinsics.fx *= 0.9;  // cam3's corners came from another lens
  s.set.cameras[2].intrinsics.fy *= 0.9;
  try {
    calibrate(s.set);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera cam3: corner reprojection rms"), std::string::npos)
        << e.what();
  }
}

TEST(CalibrationSolver, ObservationsFileRoundTrips) {
  const Synthetic s = makeRig(18, 4, 0.15, 0.008);
  const ObservationSet back = parseObservations(observationsToYaml(s.set), "test");
  ASSERT_EQ(back.observations.size(), s.set.observations.size());
  EXPECT_EQ(back.cameras[1].name, "cam2");
  EXPECT_NEAR(back.observations[3].corners[5].uv.x(), s.set.observations[3].corners[5].uv.x(), 1e-3);
  EXPECT_NEAR(back.observations[3].depth[7].z, s.set.observations[3].depth[7].z, 1e-5);
  EXPECT_TRUE(back.anchor.placement.has_value());
}

TEST(CalibrationSolver, ObservationsFileErrorsNameTheField) {
  const Synthetic s = makeRig(19, 2, 0.15, 0.008);
  std::string text = observationsToYaml(s.set);
  const std::string bad = text.substr(0, text.find("camera: cam1")) + "camera: cam9" +
                          text.substr(text.find("camera: cam1") + 12);
  try {
    parseObservations(bad, "obs.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera 'cam9' is not in 'cameras'"), std::string::npos)
        << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// The camera's own weak-return bias law (core/calibration/weak_return_fit.hpp).

namespace {

/// Placements of a board whose white print returns amplitude a_light (varied per placement) and
/// whose black print is below the law's floor; each placement's plane off by a random offset
/// (the solved plane's error), depth noise sigma, and a share of wild samples.
std::vector<WeakReturnSample> twoPrints(double B, int placements, double sigma, double wild,
                                        uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma), plane(0.0, 0.004);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const kinect_v2::AmplitudeModel law;
  std::vector<WeakReturnSample> out;
  for (int g = 0; g < placements; ++g) {
    const double offset = plane(rng), a_light = 0.05 + 0.2 * uni(rng);
    for (int i = 0; i < 200; ++i) {
      const double a = i % 2 ? a_light * (0.9 + 0.2 * uni(rng)) : 0.002 + 0.01 * uni(rng);
      const double bias = B * std::pow(std::max(a, law.bias_min_amplitude), -law.bias_power);
      double r = offset + bias + noise(rng);
      if (uni(rng) < wild) r += 0.1 * (uni(rng) - 0.5);
      out.push_back({g, a, r});
    }
  }
  return out;
}

}  // namespace

TEST(WeakReturnFit, LearnsTheCamerasOwnBiasFromTheTwoPrints) {
  const kinect_v2::AmplitudeModel law;
  for (uint32_t seed : {1u, 2u, 3u}) {
    const double B = 1.5 * law.bias_coeff;
    // Noise of a weak return (about 2 cm on the black print), 5 % wild samples.
    const WeakReturnFit fit = fitWeakReturnBias(twoPrints(B, 8, 0.02, 0.05, seed), law);
    ASSERT_TRUE(fit.fitted) << "seed " << seed << ": " << fit.note;
    EXPECT_NEAR(fit.coeff, B, 0.1 * B) << "seed " << seed;
    EXPECT_GT(fit.coeff_sigma, 0.0) << "seed " << seed;
    EXPECT_EQ(fit.groups, 8);
    // The offset that goes with it: the plane offsets' median, the bias at the floor apart.
    const double at_floor = B * std::pow(law.bias_min_amplitude, -law.bias_power);
    EXPECT_NEAR(fit.offset_shift, at_floor, 0.006) << "seed " << seed;
  }
}

TEST(WeakReturnFit, KeepsTheSensorsLawWhereThePrintsShowNoContrast) {
  const kinect_v2::AmplitudeModel law;
  // Both prints below the floor (a board 6 m away): every sample reads the same bias.
  std::vector<WeakReturnSample> far = twoPrints(law.bias_coeff, 10, 0.01, 0.0, 4);
  for (WeakReturnSample& s : far) s.amplitude = std::min(s.amplitude, 0.015);
  const WeakReturnFit fit = fitWeakReturnBias(far, law);
  EXPECT_FALSE(fit.fitted);
  EXPECT_EQ(fit.groups, 0);
  EXPECT_NE(fit.note.find("hold the board nearer"), std::string::npos) << fit.note;
  // Too few placements with contrast.
  const WeakReturnFit few = fitWeakReturnBias(twoPrints(law.bias_coeff, 3, 0.01, 0.0, 5), law);
  EXPECT_FALSE(few.fitted);
  EXPECT_EQ(few.groups, 3);
  // A sensor without the bias: B zero within its noise, used as 0.
  const WeakReturnFit none = fitWeakReturnBias(twoPrints(0.0, 8, 0.005, 0.0, 6), law);
  EXPECT_TRUE(none.fitted) << none.note;
  EXPECT_NEAR(none.coeff, 0.0, 0.1 * law.bias_coeff);
  // A camera within a few percent of the sensor's B keeps the sensor's law.
  const WeakReturnFit same =
      fitWeakReturnBias(twoPrints(1.05 * law.bias_coeff, 8, 0.005, 0.0, 8), law);
  EXPECT_FALSE(same.fitted);
  EXPECT_NE(same.note.find("of the sensor's, within 20 %"), std::string::npos) << same.note;
  EXPECT_NEAR(same.coeff, 1.05 * law.bias_coeff, 0.05 * law.bias_coeff);
  // A bias that shrinks as the return weakens is not a weak-return bias.
  const WeakReturnFit wrong =
      fitWeakReturnBias(twoPrints(-law.bias_coeff, 8, 0.005, 0.0, 7), law);
  EXPECT_FALSE(wrong.fitted);
  EXPECT_NE(wrong.note.find("shrinks"), std::string::npos) << wrong.note;
}

TEST(WeakReturnFit, AmplitudeSamplesRoundTripAndBadOnesNameTheField) {
  Synthetic s = makeRig(20, 2, 0.15, 0.008);
  s.set.observations[1].amplitude = {{100.5, 80.0, 5.123, 0.0213}, {101.5, 80.0, 5.2, 0.0015}};
  s.set.observations[1].depth[0].amplitude = 0.0225;  // a sample the capture corrected
  const std::string text = observationsToYaml(s.set);
  const ObservationSet back = parseObservations(text, "obs.yaml");
  EXPECT_NEAR(back.observations[1].depth[0].amplitude, 0.0225, 1e-7);
  EXPECT_EQ(back.observations[1].depth[1].amplitude, 0.0);
  ASSERT_EQ(back.observations[1].amplitude.size(), 2u);
  EXPECT_NEAR(back.observations[1].amplitude[0].amplitude, 0.0213, 1e-7);
  EXPECT_NEAR(back.observations[1].amplitude[1].z, 5.2, 1e-5);
  EXPECT_TRUE(back.observations[0].amplitude.empty());
  const std::string bad =
      text.substr(0, text.find("0.0015")) + "-0.0015" + text.substr(text.find("0.0015") + 6);
  try {
    parseObservations(bad, "obs.yaml");
    FAIL() << "a negative amplitude was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("observations[1] amplitude[1]"), std::string::npos)
        << e.what();
  }
}
