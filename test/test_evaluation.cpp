// Evaluation: ground truth scored against itself is zero; a known offset comes back exactly; a
// known delay comes back as lag.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "drill_pipe_pose/core/evaluation.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"

using namespace drill_pipe_pose;

namespace {

// A pin-end descending at 0.2 m/s while tilting, sampled at 100 Hz for 2 s.
GroundTruthTrack movingTrack() {
  GroundTruthTrack t;
  for (int i = 0; i <= 200; ++i) {
    const double s = i * 0.01;
    t.add(static_cast<int64_t>(1e9 * (100 + s)),
          canonicalPose({4.7, 6.8, 2.0 - 0.2 * s}, {0.1 * s, 0, -1}));
  }
  return t;
}

}  // namespace

TEST(Evaluation, GroundTruthAgainstItselfIsZero) {
  std::array<GroundTruthTrack, kNumEnds> truth;
  truth[1] = movingTrack();
  std::vector<EstimateSample> est;
  for (int k = 0; k < 60; ++k) {  // 30 Hz cycles, off the ground-truth sample times
    EstimateSample s;
    s.stamp_ns = static_cast<int64_t>(1e9 * (100.005 + k / 30.0));
    s.label = EndLabel::kPinEnd;
    s.valid = true;
    ASSERT_TRUE(truth[1].at(s.stamp_ns, &s.T_world_end));
    est.push_back(s);
  }
  const auto ev = evaluate(truth, est);
  EXPECT_FALSE(ev[0].present);
  ASSERT_TRUE(ev[1].present);
  EXPECT_EQ(ev[1].stats.expected_cycles, 60u);
  EXPECT_EQ(ev[1].stats.estimates, 60u);
  EXPECT_NEAR(ev[1].stats.max_position_error, 0.0, 1e-12);
  EXPECT_NEAR(ev[1].stats.max_axis_angle, 0.0, 1e-7);
  EXPECT_DOUBLE_EQ(ev[1].stats.fractionWithin(0.01, 0.0175), 1.0);
}

TEST(Evaluation, KnownOffsetComesBackExactly) {
  std::array<GroundTruthTrack, kNumEnds> truth;
  truth[0].add(0, canonicalPose({4.694, 5.3, 0.23}, {0, 0, 1}));
  truth[0].add(10000000000, canonicalPose({4.694, 5.3, 0.23}, {0, 0, 1}));
  const double tilt = 1.5 * M_PI / 180;
  std::vector<EstimateSample> est;
  for (int k = 0; k < 300; ++k) {
    EstimateSample s;
    s.stamp_ns = static_cast<int64_t>(k * 1e9 / 30);
    s.valid = k % 10 != 0;  // every tenth cycle invalid: a failure, not an estimate
    s.T_world_end = canonicalPose({4.694 + 0.003, 5.3 - 0.004, 0.23 + 0.012},
                                  {std::sin(tilt), 0, std::cos(tilt)});
    s.covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 1e-4;  // 1 cm sigma
    // Tilt sigma 0.01 rad in even cycles (3 sigma > the 1.5 deg tilt), 0.005 in odd ones (<).
    const double tilt_sigma = k % 2 == 0 ? 0.01 : 0.005;
    s.covariance.bottomRightCorner<3, 3>() =
        Eigen::Vector3d(tilt_sigma * tilt_sigma, tilt_sigma * tilt_sigma, 1e3).asDiagonal();
    est.push_back(s);
  }
  const auto ev = evaluate(truth, est);
  const ErrorStats& s = ev[0].stats;
  EXPECT_EQ(s.expected_cycles, 300u);
  EXPECT_EQ(s.estimates, 270u);
  EXPECT_NEAR(s.mean_error.x(), 0.003, 1e-12);
  EXPECT_NEAR(s.mean_error.y(), -0.004, 1e-12);
  EXPECT_NEAR(s.mean_error.z(), 0.012, 1e-12);
  EXPECT_NEAR(s.mean_position_error, 0.013, 1e-12);
  EXPECT_NEAR(s.std_position.norm(), 0.0, 1e-12);
  EXPECT_NEAR(s.mean_along, 0.012, 1e-12);
  EXPECT_NEAR(s.mean_axis_angle, tilt, 1e-9);
  EXPECT_NEAR(s.mean_rotation.y(), tilt, 1e-9);
  EXPECT_NEAR(s.fractionWithin(0.02, 2 * M_PI / 180), 0.9, 1e-12);
  EXPECT_DOUBLE_EQ(s.fractionWithin(0.01, 1), 0.0);
  EXPECT_DOUBLE_EQ(ev[0].within_3sigma, 1.0);  // 13 mm < 3 * 10 mm
  // 120 of the 270 valid estimates are even cycles (the invalid tenth ones are all even).
  EXPECT_NEAR(ev[0].axis_within_3sigma, 120.0 / 270.0, 1e-12);
  std::ostringstream table, csv;
  printEvaluation(ev, table);
  writeErrorCsv(ev, csv);
  EXPECT_NE(table.str().find("box_end: 270 estimates / 300 expected cycles"), std::string::npos)
      << table.str();
  EXPECT_NE(csv.str().find("box_end,0.003"), std::string::npos);
}

TEST(Evaluation, InterpolatesBetweenSamples) {
  const GroundTruthTrack t = movingTrack();
  Eigen::Isometry3d T;
  ASSERT_TRUE(t.at(static_cast<int64_t>(1e9 * 100.505), &T));
  EXPECT_NEAR(T.translation().z(), 2.0 - 0.2 * 0.505, 1e-9);
  EXPECT_FALSE(t.at(static_cast<int64_t>(1e9 * 99), &T));
}

TEST(Evaluation, LagIsTheSignedErrorAlongTheMotion) {
  // Estimates 40 ms late on the pin end descending at 0.2 m/s: 8 mm behind (negative).
  std::array<GroundTruthTrack, kNumEnds> truth;
  truth[1] = movingTrack();
  std::vector<EstimateSample> est;
  for (int k = 5; k < 55; ++k) {
    EstimateSample s;
    s.stamp_ns = static_cast<int64_t>(1e9 * (100.0 + k / 30.0));
    s.label = EndLabel::kPinEnd;
    s.valid = true;
    ASSERT_TRUE(truth[1].at(s.stamp_ns - 40000000, &s.T_world_end));
    est.push_back(s);
  }
  const auto ev = evaluate(truth, est);
  EXPECT_EQ(ev[1].moving_estimates, 50u);
  EXPECT_NEAR(ev[1].mean_lag, -0.008, 2e-4);
  // A static end has no lag figure.
  std::array<GroundTruthTrack, kNumEnds> still;
  still[0].add(0, canonicalPose({4.694, 5.3, 0.23}, {0, 0, 1}));
  still[0].add(10000000000, canonicalPose({4.694, 5.3, 0.23}, {0, 0, 1}));
  EstimateSample s;
  s.stamp_ns = 5000000000;
  s.valid = true;
  s.T_world_end = canonicalPose({4.7, 5.3, 0.23}, {0, 0, 1});
  const auto ev0 = evaluate(still, {s});
  EXPECT_EQ(ev0[0].moving_estimates, 0u);
  EXPECT_TRUE(std::isnan(ev0[0].mean_lag));
}

TEST(Evaluation, EveryEndCountsReportsOnAnotherEndAndKeepsExamples) {
  // Two box ends and a pin end; in each of two cycles the box ends are reported on their own, and
  // a box-end report sits 0.12 m from the pin end (a box fit on it): stray, near another end, and
  // kept as an example for the diagnosis.
  TrueEnds truth;
  const Eigen::Vector3d a(7.2, 5.85, 1.08), b(7.2, 6.25, 1.08), pin(2.2, 5.85, 1.08);
  std::vector<ReportedEnd> reports;
  for (int64_t stamp : {1000000000LL, 1033000000LL}) {
    truth[0][stamp] = {a, b};
    truth[1][stamp] = {pin};
    reports.push_back({stamp, EndLabel::kBoxEnd, 1, a});
    reports.push_back({stamp, EndLabel::kBoxEnd, 2, b});
    reports.push_back({stamp, EndLabel::kPinEnd, 3, pin});
    reports.push_back({stamp, EndLabel::kBoxEnd, 4, pin + Eigen::Vector3d(-0.12, 0, 0)});
  }
  const InstanceEvaluation ev = evaluateInstances(truth, reports);
  EXPECT_EQ(ev.true_ends, 3u);
  EXPECT_EQ(ev.reported, ev.end_cycles);
  EXPECT_EQ(ev.id_kept, ev.id_pairs);
  EXPECT_EQ(ev.stray, 2u);
  EXPECT_EQ(ev.near_other, 2u);
  ASSERT_EQ(ev.near_examples.size(), 2u);
  EXPECT_EQ(ev.near_examples[0].id, 4u);
  EXPECT_EQ(ev.near_examples[0].label, EndLabel::kBoxEnd);
  // The stray report kept with its distance to its label's nearest true end (box end a: 5 m).
  ASSERT_EQ(ev.stray_examples.size(), 2u);
  EXPECT_EQ(ev.stray_examples[0].first.id, 4u);
  EXPECT_NEAR(ev.stray_examples[0].second, (pin + Eigen::Vector3d(-0.12, 0, 0) - a).norm(), 1e-9);
}

TEST(Evaluation, EveryEndTalliesThePublishedTypesPerTrueEnd) {
  // One box end reported in three cycles: twice as "4in" (probabilities 0.7 / 0.3), once as
  // "5in" (0.4 / 0.6). Its tally: 2 and 1 reports per type, the probabilities summed, and each
  // type's least probability in a report that published the other. A report without a type
  // counts as reported, not in the tally.
  TrueEnds truth;
  const Eigen::Vector3d a(4.694, 4.85, 0.6);
  const std::vector<std::string> names{"4in", "5in"};
  std::vector<ReportedEnd> reports;
  const int64_t t0 = 1000000000LL, dt = 33000000LL;
  for (int k = 0; k < 4; ++k) truth[0][t0 + k * dt] = {a};
  reports.push_back({t0, EndLabel::kBoxEnd, 1, a, "4in", names, {0.7, 0.3}});
  reports.push_back({t0 + dt, EndLabel::kBoxEnd, 1, a, "5in", names, {0.4, 0.6}});
  reports.push_back({t0 + 2 * dt, EndLabel::kBoxEnd, 1, a, "4in", names, {0.8, 0.2}});
  reports.push_back({t0 + 3 * dt, EndLabel::kBoxEnd, 1, a});
  const InstanceEvaluation ev = evaluateInstances(truth, reports);
  EXPECT_EQ(ev.reported, 4u);
  ASSERT_EQ(ev.types.count({0, 0}), 1u);
  const TrueEndTypes& ty = ev.types.at({0, 0});
  EXPECT_EQ(ty.reports, 3u);
  EXPECT_EQ(ty.top.at("4in"), 2u);
  EXPECT_EQ(ty.top.at("5in"), 1u);
  EXPECT_NEAR(ty.probability.at("4in"), 1.9, 1e-12);
  EXPECT_NEAR(ty.probability.at("5in"), 1.1, 1e-12);
  EXPECT_NEAR(ty.least_not_top.at("4in"), 0.4, 1e-12);  // in the report that published 5in
  EXPECT_NEAR(ty.least_not_top.at("5in"), 0.2, 1e-12);
  EXPECT_NEAR((ty.position - a).norm(), 0.0, 1e-12);
  // No report published its type above 0.9; one more that does counts as confident.
  EXPECT_TRUE(ty.confident.empty());
  TypeTally more = ty;
  more.add("5in", names, {0.05, 0.95});
  EXPECT_EQ(more.confident.at("5in"), 1u);
  EXPECT_EQ(more.confident.count("4in"), 0u);
}

TEST(Evaluation, ReportedSigmaAgainstTheActualErrorAndTheFreshPoses) {
  // A static end, a reported position variance of 24 mm^2 per axis (trace 72 mm^2). Fresh
  // estimates are 6 mm off along x; every third estimate is a repeated one (not fresh), 20 mm
  // off: it counts in sigma / error = sqrt(mean trace / mean |error|^2), not in the fresh
  // poses' percentiles.
  std::array<GroundTruthTrack, kNumEnds> truth;
  truth[0].add(0, canonicalPose({4.694, 5.3, 0.23}, {0, 0, 1}));
  truth[0].add(10000000000, canonicalPose({4.694, 5.3, 0.23}, {0, 0, 1}));
  std::vector<EstimateSample> est;
  for (int k = 0; k < 90; ++k) {
    EstimateSample s;
    s.stamp_ns = static_cast<int64_t>(k * 1e9 / 30);
    s.valid = true;
    s.fresh = k % 3 != 0;
    const double off = s.fresh ? 0.006 : 0.020;
    s.T_world_end = canonicalPose({4.694 + off, 5.3, 0.23}, {0, 0, 1});
    s.covariance.setZero();
    s.covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 24e-6;
    s.covariance.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * 1e-4;
    est.push_back(s);
  }
  const auto ev = evaluate(truth, est);
  ASSERT_TRUE(ev[0].present);
  // Mean |error|^2 over all 90: (60 * 36 + 30 * 400) / 90 mm^2; trace 72 mm^2.
  const double err2 = (60 * 36.0 + 30 * 400.0) / 90.0;
  EXPECT_NEAR(ev[0].sigma_to_error, std::sqrt(72.0 / err2), 1e-6);
  EXPECT_NEAR(ev[0].fresh_median_error, 0.006, 1e-9);
  EXPECT_NEAR(ev[0].fresh_p95_error, 0.006, 1e-9);

  // Without any fresh estimate (and without covariance) both are NaN, not 0.
  for (auto& s : est) {
    s.fresh = false;
    s.covariance.setZero();
  }
  const auto none = evaluate(truth, est);
  EXPECT_TRUE(std::isnan(none[0].sigma_to_error));
  EXPECT_TRUE(std::isnan(none[0].fresh_median_error));
  EXPECT_TRUE(std::isnan(none[0].fresh_p95_error));
}

TEST(Evaluation, TheJointsAsRenderedReadBackAndBadEntriesAreNamed) {
  const std::vector<TrueJoint> joints = {{EndLabel::kBoxEnd, "box_sample", 0.168275, 0.1665014},
                                         {EndLabel::kPinEnd, "pin sample", 0.1778, 0.17693426}};
  const std::vector<TrueJoint> back = parseTrueJoints(trueJointsYaml(joints));
  ASSERT_EQ(back.size(), joints.size());
  for (size_t i = 0; i < joints.size(); ++i) {
    EXPECT_EQ(back[i].label, joints[i].label) << i;
    EXPECT_EQ(back[i].pipe, joints[i].pipe) << i;
    EXPECT_NEAR(back[i].nominal_od, joints[i].nominal_od, 1e-12) << i;
    EXPECT_NEAR(back[i].rendered_od, joints[i].rendered_od, 1e-12) << i;
  }
  EXPECT_TRUE(parseTrueJoints("[]").empty());
  auto error = [](const std::string& yaml) {
    try {
      parseTrueJoints(yaml);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("{label: box_end}").find("a list of joints"), std::string::npos);
  EXPECT_NE(
      error("- {label: box_end, pipe: a, nominal_od: 0.17}").find("[0]: no field 'rendered_od'"),
      std::string::npos);
  EXPECT_NE(error("- {label: box_end, pipe: a, nominal_od: 0.17, rendered_od: 0.17}\n"
                  "- {label: tool_joint, pipe: a, nominal_od: 0.17, rendered_od: 0.17}")
                .find("[1].label"),
            std::string::npos);
  EXPECT_NE(error("- {label: pin_end, pipe: a, nominal_od: 0.17, rendered_od: wide}").find("[0]"),
            std::string::npos);
  EXPECT_NE(error("- {label: pin_end, pipe: a, nominal_od: 0.17, rendered_od: 0}").find("positive"),
            std::string::npos);
}
