// Error metrics: analytic cases, roll ignored, statistics.
#include <gtest/gtest.h>

#include <cmath>

#include "drill_pipe_pose/core/metrics.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"

using namespace drill_pipe_pose;

TEST(Metrics, PositionSplitsAlongAndAcrossTheTrueAxis) {
  const auto truth = canonicalPose({1, 2, 3}, {0, 0, 1});
  const auto est = canonicalPose({1.003, 2.004, 3.012}, {0, 0, 1});
  const PoseError e = poseError(truth, est);
  EXPECT_NEAR(e.position_norm, 0.013, 1e-12);
  EXPECT_NEAR(e.along_axis, 0.012, 1e-12);
  EXPECT_NEAR(e.across_axis, 0.005, 1e-12);
  EXPECT_NEAR(e.axis_angle, 0.0, 1e-12);
}

TEST(Metrics, AxisAngleAndRotationVectorIgnoreRoll) {
  const auto truth = canonicalPose({0, 0, 0}, {0, 0, 1});
  const double tilt = 2.0 * M_PI / 180;
  Eigen::Isometry3d est = canonicalPose({0, 0, 0}, {std::sin(tilt), 0, std::cos(tilt)});
  est.linear() = est.linear() * Eigen::AngleAxisd(2.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const PoseError e = poseError(truth, est);
  EXPECT_NEAR(e.axis_angle, tilt, 1e-9);
  // A tilt toward +x is a rotation about +y, whatever the estimate's roll.
  EXPECT_NEAR(e.rotation_vector.y(), tilt, 1e-6);
  EXPECT_NEAR(e.rotation_vector.x(), 0.0, 1e-6);
}

TEST(Metrics, StatisticsAndSuccessFraction) {
  std::vector<PoseError> errors;
  std::vector<Eigen::Vector3d> positions;
  const auto truth = canonicalPose({0, 0, 0}, {0, 0, 1});
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3d p(0.001 * i, 0, 0);
    errors.push_back(poseError(truth, canonicalPose(p, {0, 0, 1})));
    positions.push_back(p);
  }
  const ErrorStats s = computeStats(errors, positions, 20);
  EXPECT_EQ(s.estimates, 10u);
  EXPECT_NEAR(s.mean_position_error, 0.0045, 1e-12);
  EXPECT_NEAR(s.mean_position.x(), 0.0045, 1e-12);
  EXPECT_NEAR(s.std_position.x(), std::sqrt(82.5e-6 / 9), 1e-9);  // sample std of 0..9 mm
  EXPECT_NEAR(s.max_position_error, 0.009, 1e-12);
  EXPECT_NEAR(s.p50_position_error, 0.0045, 1e-12);
  // 5 of the 20 expected cycles are within 4.5 mm: missing cycles count as failures.
  EXPECT_NEAR(s.fractionWithin(0.0045, 0.01), 5.0 / 20.0, 1e-12);
  EXPECT_DOUBLE_EQ(percentile({}, 0.5), 0.0);
}

TEST(Metrics, UpperMedianIsAValueOfTheSet) {
  EXPECT_DOUBLE_EQ(upperMedian({}), 0.0);
  EXPECT_DOUBLE_EQ(upperMedian({4.0}), 4.0);
  EXPECT_DOUBLE_EQ(upperMedian({9.0, 1.0, 5.0}), 5.0);
  // An even count: the upper of the two middle values, not their mean (3.5).
  EXPECT_DOUBLE_EQ(upperMedian({4.0, 1.0, 3.0, 8.0}), 4.0);
  // One far value does not move it.
  EXPECT_DOUBLE_EQ(upperMedian({2.0, 2.1, 1.9, 1e9, 2.05}), 2.05);
}
