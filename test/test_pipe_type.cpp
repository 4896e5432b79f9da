// The pipe-type evidence of one end (core/estimator/pipe_type.hpp): deterministic measurements.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "drill_pipe_pose/core/estimator/pipe_type.hpp"

using namespace drill_pipe_pose;

namespace {

PipeCandidate type(const char* name, double joint_od, double tube_od) {
  PipeCandidate c;
  c.name = name;
  c.dims.tool_joint_od = joint_od;
  c.dims.tube_od = tube_od;
  return c;
}

/// 6-5/8" joints on a 4-1/2" and a 5" tube (the same joint OD), and a 7" joint on 5-1/2".
const std::vector<PipeCandidate> kTypes{type("4.5_NC50", 0.1683, 0.1143),
                                        type("5_NC50", 0.1683, 0.1270),
                                        type("5.5_FH", 0.1778, 0.1397)};

/// n joint measurements at radius r (alternating +-scatter), and m tube ones at radius t.
TypeEvidence measured(double r, int n, double t = 0, int m = 0, double scatter = 0.001) {
  TypeEvidence e;
  for (int i = 0; i < n; ++i) e.joint.add(r + (i % 2 ? scatter : -scatter), 0.001);
  for (int i = 0; i < m; ++i) e.tube.add(t + (i % 2 ? scatter : -scatter), 0.001);
  return e;
}

}  // namespace

TEST(PipeType, UniformWithoutAMeasurement) {
  const std::vector<double> p = TypeEvidence().probabilities(kTypes, TypingConfig());
  ASSERT_EQ(p.size(), 3u);
  for (double v : p) EXPECT_NEAR(v, 1.0 / 3, 1e-12);
  EXPECT_EQ(topType({}), -1);
}

TEST(PipeType, JointOdsTenMillimetresApartAreToldApart) {
  // 9.5 mm apart (6-5/8" and 7"), the 6-5/8" one twice (two tubes): 1.4 % left to them.
  const std::vector<double> p = measured(0.1778 / 2, 50).probabilities(kTypes, TypingConfig());
  EXPECT_EQ(topType(p), 2);
  EXPECT_GT(p[2], 0.98);
  const std::vector<double> q = measured(0.1683 / 2 + 0.005, 50).probabilities(
      {kTypes[1], type("10mm_larger", 0.1683 + 0.01, 0.127)}, TypingConfig());
  EXPECT_LT(q[0], 0.01);  // the larger joint measured: the smaller one is out
  EXPECT_GT(q[0], 0.0);
  // The smaller joint measured: a worn larger one stays possible (wear allowance), yet below.
  const std::vector<double> w = measured(0.1683 / 2, 50).probabilities(
      {kTypes[1], type("10mm_larger", 0.1683 + 0.01, 0.127)}, TypingConfig());
  EXPECT_EQ(topType(w), 0);
  EXPECT_GT(w[0], 0.9);
}

TEST(PipeType, SameJointOdStaysAmbiguousUntilTheTubeIsSeen) {
  const TypingConfig c;
  const std::vector<double> p = measured(0.1683 / 2, 200).probabilities(kTypes, c);
  EXPECT_NEAR(p[0], p[1], 1e-9);
  EXPECT_LT(p[0], 0.51);  // never a confident answer
  // A few tube measurements (fewer than min_measurements) do not count...
  const std::vector<double> q =
      measured(0.1683 / 2, 200, 0.1270 / 2, c.min_measurements - 1).probabilities(kTypes, c, 1);
  EXPECT_NEAR(q[0], q[1], 1e-9);
  // ...enough of them (the tubes are 12.7 mm apart) decide.
  const std::vector<double> t =
      measured(0.1683 / 2, 200, 0.1270 / 2, c.min_measurements).probabilities(kTypes, c, 1);
  EXPECT_EQ(topType(t), 1);
  EXPECT_LT(t[0], 0.001);  // the tube decides between the two...
  EXPECT_GT(t[1], 0.95);   // ...the 7" joint keeps what the joint alone leaves it (4.6 %)
  // Measured against the 7" model (another joint size) the tube does not count.
  const std::vector<double> o =
      measured(0.1683 / 2, 200, 0.1270 / 2, c.min_measurements).probabilities(kTypes, c, 2);
  EXPECT_NEAR(o[0], o[1], 1e-9);
}

TEST(PipeType, AWornJointKeepsItsNominalType) {
  // 3 mm under nominal OD: as likely as the nominal joint itself; the two 6-5/8" types, 6.5 mm
  // under it, keep 8 % each (typing.systematic).
  const std::vector<double> worn =
      measured(0.1778 / 2 - 0.0015, 100).probabilities(kTypes, TypingConfig());
  EXPECT_EQ(topType(worn), 2);
  EXPECT_GT(worn[2], 0.8);
}

TEST(PipeType, ASharedBiasNeverMakesItConfident) {
  // A joint read 2 mm large in radius (a depth bias every measurement shares) halfway to the
  // next size: 10^4 measurements are no surer than 10, since the systematic part stays.
  const double r = 0.1683 / 2 + 0.002;
  const std::vector<double> few = measured(r, 10).probabilities(kTypes, TypingConfig());
  const std::vector<double> many = measured(r, 10000).probabilities(kTypes, TypingConfig());
  EXPECT_GT(many[2], 0.05) << "the next size stays possible";
  EXPECT_NEAR(many[2], few[2], 0.05);
}

TEST(PipeType, BadMeasurementsAreIgnored) {
  TypeEvidence e;
  e.joint.add(std::nan(""), 0.001);
  e.joint.add(0.08, std::numeric_limits<double>::infinity());
  EXPECT_EQ(e.joint.count(), 0u);
}

namespace {
/// One joint per catalogue OD class: 4-3/4", 6-1/4", 6-3/8", 6-5/8" (twice: two tubes), 7".
const std::vector<PipeCandidate> kSizes{
    type("3.5_NC38", 0.12065, 0.0889), type("4.5_NC46", 0.15875, 0.1143),
    type("4.5_NC50", 0.16193, 0.1143), type("5_NC50", 0.16828, 0.1270),
    type("5_NC50_twin", 0.16828, 0.1270), type("5.5_FH", 0.1778, 0.1397)};

TypeTrial trial(int type, double offset, bool ok = true) {
  TypeTrial t;
  t.type = type;
  t.ok = ok;
  t.offset = offset;
  return t;
}
}  // namespace

TEST(PipeTypeTrial, NoTrialWhileTheJointReadsItsOwnRadius) {
  EXPECT_EQ(trialTypes(kSizes, 3, 0.16828 / 2, TypingConfig()), std::vector<int>{3});
  // 1 mm thin: the window reaches 4.5 mm of radius down, to the 6-3/8" joint (3.2 mm).
  EXPECT_EQ(trialTypes(kSizes, 3, 0.16828 / 2 - 0.001, TypingConfig()),
            (std::vector<int>{3, 2}));
}

TEST(PipeTypeTrial, ATinyJointTriesEverySmallerOdOnce) {
  // A 4-3/4" joint reads halfway to the 6-5/8" model: 144.5 mm.
  const std::vector<int> t = trialTypes(kSizes, 3, 0.1445 / 2, TypingConfig());
  EXPECT_EQ(t, (std::vector<int>{3, 0, 1, 2})) << "each smaller OD once, none larger, no twin";
  // The other side: a 7" joint read at 173 mm.
  EXPECT_EQ(trialTypes(kSizes, 3, 0.173 / 2, TypingConfig()), (std::vector<int>{3, 5}));
  EXPECT_TRUE(trialTypes(kSizes, -1, 0.08, TypingConfig()).empty());
}

TEST(PipeTypeTrial, TheTypeThatExplainsItsRadiusWins) {
  const TypingConfig c;
  // Against its own model the 4-3/4" joint reads +0.3 mm; against the others it reads thinner.
  EXPECT_EQ(chooseTrial({trial(3, -11.0e-3), trial(0, 0.3e-3), trial(1, -9.0e-3)}, c), 0);
  // A joint 1.5 mm (radius) worn reads -0.75 mm against its own model: it keeps it, though
  // the next smaller size reads +0.8 mm.
  EXPECT_EQ(chooseTrial({trial(3, -0.75e-3), trial(2, 0.8e-3)}, c), 3);
  // Within trial_margin the current type stays.
  EXPECT_EQ(chooseTrial({trial(3, 0.4e-3), trial(2, 0.3e-3)}, c), 3);
  // A failed trial does not count; none ok: -1.
  EXPECT_EQ(chooseTrial({trial(3, 5e-3), trial(0, 0.0, false)}, c), 3);
  EXPECT_EQ(chooseTrial({trial(3, 0.0, false), trial(0, 1e-3)}, c), 0);
  EXPECT_EQ(chooseTrial({trial(3, 0.0, false)}, c), -1);
  EXPECT_EQ(chooseTrial({}, c), -1);
  // The configured type wins typing.prior_margin back: a worn joint read 1.9 mm thin against it
  // and 0.2 mm thick against the next smaller size keeps the configured type, not another.
  EXPECT_EQ(chooseTrial({trial(3, -1.9e-3), trial(2, 0.2e-3)}, c, 3), 3);
  EXPECT_EQ(chooseTrial({trial(3, -1.9e-3), trial(2, 0.2e-3)}, c), 2);
  EXPECT_EQ(chooseTrial({trial(2, 0.2e-3), trial(3, -1.9e-3)}, c, 3), 3) << "also back to it";
}
