// The pipe-type evidence of one end (core/estimator/pipe_type.hpp): deterministic measurements.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
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
  // The smaller joint measured: the larger one stays possible (typing.systematic), yet below.
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

TEST(PipeType, AWornJointKeepsItsNominalTypeWithTheWearAllowance) {
  // With typing.wear at 1.5 mm (0.5 mm by default), 3 mm under nominal OD is as likely as the
  // nominal joint itself; the two 6-5/8" types, 6.5 mm under it, keep 8 % each
  // (typing.systematic).
  TypingConfig c;
  c.wear = 0.0015;
  const std::vector<double> worn = measured(0.1778 / 2 - 0.0015, 100).probabilities(kTypes, c);
  EXPECT_EQ(topType(worn), 2);
  EXPECT_GT(worn[2], 0.8);
}

TEST(PipeType, AJointReadOverItsRadiusIsNotPushedToTheNextLargerSize) {
  // The searched radius reads joints at or over nominal (TypingConfig::wear): a 6-3/8" joint
  // read 0.3 mm over its radius keeps more than half the probability by default (0.57). The
  // old wear allowance of 1.5 mm made the 6-5/8" joint, 3.2 mm over it, nearly as likely.
  const std::vector<PipeCandidate> three{type("4.5_NC46", 0.15875, 0.1143),
                                         type("4.5_NC50", 0.16193, 0.1143),
                                         type("5_NC50", 0.16828, 0.1270)};
  const TypeEvidence e = measured(0.16193 / 2 + 0.0003, 100);
  const std::vector<double> p = e.probabilities(three, TypingConfig());
  EXPECT_EQ(topType(p), 1);
  EXPECT_GT(p[1], 0.5);
  TypingConfig worn;
  worn.wear = 0.0015;
  const std::vector<double> q = e.probabilities(three, worn);
  EXPECT_LT(q[1], 0.5) << "the allowance takes the true type's probability below half";
  EXPECT_GT(q[2], 0.25);
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

TEST(SearchedRadii, ASearchFarOffItsMedianDoesNotPullTheMean) {
  // The catwalk's lying pin end (seed 200): readings scattering about the 5" OD joint's radius,
  // and now and then a search that ran to the end of its range (the catalogue's thinnest joint
  // less 10 mm). A plain mean follows those; the searched radii leave them out.
  const double truth = 0.127 / 2, wild = 0.1006 / 2;
  SearchedRadii searched;
  RadiusMean plain;
  for (int i = 0; i < 20; ++i) {
    const double r = (i % 5 == 4) ? wild : truth + 0.002 * std::sin(1.0 + i);
    searched.add(r, 0.002);
    plain.add(r, 0.002);
  }
  EXPECT_EQ(plain.count(), 20u);
  EXPECT_EQ(searched.count(), 16u) << "the four wild searches left out";
  EXPECT_EQ(searched.added(), 20u) << "yet counted as searches";
  EXPECT_DOUBLE_EQ(searched.last(), wild);
  EXPECT_NEAR(searched.mean(), truth, 0.001);
  EXPECT_LT(plain.mean(), truth - 0.002) << "a plain mean follows them";
  EXPECT_LT(searched.spread(), 0.5 * plain.spread());
}

TEST(SearchedRadii, FewSearchesAllCount) {
  // The median absolute deviation of a few searches is no spread (drill_floor, seed 205: 155.1,
  // 155.7 and 171.2 mm, the last one right): under ten, every search counts.
  SearchedRadii s;
  for (int i = 0; i < 6; ++i) s.add(0.07, 0.002);
  s.add(0.0725, 0.002);
  s.add(0.08, 0.002);
  EXPECT_EQ(s.count(), 8u);
  // Ten: equal readings have no deviation, so half the stated error is the floor: 2.5 mm off
  // still counts (within 3 x 1 mm), 10 mm off does not.
  s.add(0.07, 0.002);
  s.add(0.07, 0.002);
  EXPECT_EQ(s.count(), 9u);
  EXPECT_EQ(s.added(), 10u);
  // Bad readings are ignored, as by any RadiusMean.
  s.add(std::nan(""), 0.002);
  EXPECT_EQ(s.added(), 10u);
}

TEST(SearchedRadii, TheOldestSearchesRollOff) {
  // A long track: its first searches (read while fitted with another size's model) go once
  // kWindow later ones have come.
  SearchedRadii searched;
  for (size_t i = 0; i < SearchedRadii::kWindow; ++i) searched.add(0.084, 0.001);
  for (size_t i = 0; i < SearchedRadii::kWindow; ++i) searched.add(0.0762, 0.001);
  EXPECT_EQ(searched.count(), SearchedRadii::kWindow);
  EXPECT_NEAR(searched.mean(), 0.0762, 1e-12);
}

namespace {
/// One joint per catalogue OD class: 4-3/4", 6-1/4", 6-3/8", 6-5/8" (twice: two tubes), 7".
const std::vector<PipeCandidate> kSizes{
    type("3.5_NC38", 0.12065, 0.0889), type("4.5_NC46", 0.15875, 0.1143),
    type("4.5_NC50", 0.16193, 0.1143), type("5_NC50", 0.16828, 0.1270),
    type("5_NC50_twin", 0.16828, 0.1270), type("5.5_FH", 0.1778, 0.1397)};

/// A joint of true radius `truth` as a search sees it: against a model of radius R it reads
/// `gain` of the way from R to its own radius.
std::function<bool(double, double*, double*)> reading(double truth, double gain, int* calls) {
  return [=](double r, double* offset, double* std) {
    ++*calls;
    *offset = gain * (truth - r);
    *std = 0.0005;
    return true;
  };
}
}  // namespace

TEST(RadiusSearch, FindsTheRadiusWhateverTheGain) {
  // Halfway (the thesis lab) and a seventh of the way (a joint lying on the catwalk), from the
  // 6-5/8" model: a 4-3/4" joint and an 8" one.
  for (double gain : {0.5, 0.14, 1.0})
    for (double truth : {0.12065 / 2, 0.2032 / 2}) {
      int calls = 0;
      const RadiusSearch s = searchRadius(reading(truth, gain, &calls), 0.16828 / 2, 0.05, 0.115);
      ASSERT_TRUE(s.ok) << "gain " << gain << " truth " << truth;
      EXPECT_NEAR(s.radius, truth, 2e-4) << "gain " << gain;
      EXPECT_EQ(s.refits, calls);
      EXPECT_LE(s.refits, 5);
      EXPECT_NEAR(s.gain, gain, 1e-6);
      // The offset's 0.5 mm, over the gain: a joint that reads a seventh of the way is
      // measured seven times less precisely.
      EXPECT_NEAR(s.std, 0.0005 / gain, 1e-9) << "gain " << gain;
    }
}

TEST(RadiusSearch, StaysInItsRangeAndStopsOnAFailedRefit) {
  int calls = 0;
  // A reading off the range's end is the range's end.
  RadiusSearch s = searchRadius(reading(0.2, 0.5, &calls), 0.084, 0.05, 0.115);
  ASSERT_TRUE(s.ok);
  EXPECT_DOUBLE_EQ(s.radius, 0.115);
  // The first refit fails: no radius.
  s = searchRadius([](double, double*, double*) { return false; }, 0.084, 0.05, 0.115);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(s.refits, 1);
  // A later one fails: the radius from the last good one, at the assumed halfway gain.
  calls = 0;
  s = searchRadius(
      [&](double r, double* offset, double* std) {
        *offset = 0.5 * (0.09 - r);
        *std = calls == 0 ? 0.001 : 0.0001;
        return ++calls == 1;
      },
      0.084, 0.05, 0.115);
  ASSERT_TRUE(s.ok);
  EXPECT_NEAR(s.radius, 0.09, 1e-9);
  EXPECT_EQ(s.refits, 2);
  EXPECT_NEAR(s.std, 0.001 / 0.5, 1e-9);  // the good refit's, not the failed one's
  // NaN offsets are failures.
  s = searchRadius(
      [](double, double* offset, double*) {
        *offset = std::nan("");
        return true;
      },
      0.084, 0.05, 0.115);
  EXPECT_FALSE(s.ok);
}

TEST(RadiusProbabilities, TwoEndsCountTogether) {
  const TypingConfig c;
  RadiusMean box, pin, none;
  // The box end reads the 7" joint; the pin end, whose readings scatter by 6 mm, reads low.
  for (int i = 0; i < 10; ++i) box.add(0.1778 / 2 + (i % 2 ? 0.001 : -0.001), 0.0);
  for (int i = 0; i < 10; ++i) pin.add(0.0825 + (i % 2 ? 0.006 : -0.006), 0.0);
  const std::vector<double> alone = radiusProbabilities({&pin}, kSizes, c);
  const std::vector<double> both = radiusProbabilities({&box, &pin, &none}, kSizes, c);
  EXPECT_GT(jointOdProbability(alone, kSizes, 3), 0.3) << "the pin alone is unsure";
  EXPECT_GT(both[5], 0.9) << "with the box end: the 7\" joint";
  EXPECT_NEAR(jointOdProbability(both, kSizes, 3), both[3] + both[4], 1e-12);
  EXPECT_NEAR(both[3], both[4], 1e-12) << "one joint OD, two tubes: equal";
  // Without a measurement: uniform.
  const std::vector<double> u = radiusProbabilities({&none}, kSizes, c);
  for (double v : u) EXPECT_NEAR(v, 1.0 / kSizes.size(), 1e-12);
  EXPECT_EQ(jointOdProbability(u, kSizes, -1), 0.0);
}

TEST(PipeType, TheJointOdFromTheSearchesTheTypeWithinItFromTheEvidence) {
  // The searched radii give each joint OD its share, the evidence on the track splits a shared
  // OD between its types (the tube); a share the evidence leaves at zero is split evenly.
  const std::vector<double> by_od{0.1, 0.3, 0.6};       // 6-5/8" joints: 0.4 in all
  const std::vector<double> within{0.18, 0.72, 0.1};    // the tube says 5" (4 to 1)
  const std::vector<double> p = splitByJointOd(by_od, within, kTypes);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_NEAR(p[0], 0.08, 1e-12);
  EXPECT_NEAR(p[1], 0.32, 1e-12);
  EXPECT_NEAR(p[2], 0.6, 1e-12);  // the 7" joint: the searches' share, whatever the evidence
  const std::vector<double> q = splitByJointOd(by_od, {0.0, 0.0, 1.0}, kTypes);
  EXPECT_NEAR(q[0], 0.2, 1e-12);
  EXPECT_NEAR(q[1], 0.2, 1e-12);
  // Mismatched sizes: the searches' probabilities as they are.
  EXPECT_EQ(splitByJointOd(by_od, {1.0}, kTypes), by_od);
}

TEST(PipeTally, CloseTypesAreThePairsTheSensorCannotTellApart) {
  // 3.2 mm apart on one tube: close. 6.35 mm apart: told apart. The same joint on tubes 12.7 mm
  // apart: told apart by the tube. 3.2 mm apart on tubes 5 mm apart: close.
  const std::vector<PipeCandidate> tally{
      type("4.5_NC46_6.25", 0.15875, 0.1143), type("4.5_NC50_6.375", 0.161925, 0.1143),
      type("5_NC50", 0.168275, 0.1270), type("4.5_NC50_6.625", 0.168275, 0.1143),
      type("x_6.75", 0.17145, 0.1320)};
  const std::vector<CloseTypes> close = closeTypes(tally);
  ASSERT_EQ(close.size(), 2u);
  EXPECT_EQ(close[0].a, "4.5_NC46_6.25");
  EXPECT_EQ(close[0].b, "4.5_NC50_6.375");
  EXPECT_NEAR(close[0].joint_od_gap, 0.003175, 1e-9);
  EXPECT_EQ(close[1].a, "5_NC50");
  EXPECT_EQ(close[1].b, "x_6.75");
  EXPECT_NEAR(close[1].tube_od_gap, 0.005, 1e-9);
  // The warning names each pair, or with [all] says how to set the tally.
  const std::string named = tallyWarning(tally, false);
  EXPECT_NE(named.find("4.5_NC46_6.25 and 4.5_NC50_6.375"), std::string::npos) << named;
  EXPECT_NE(named.find("5_NC50 and x_6.75"), std::string::npos) << named;
  const std::string all = tallyWarning(tally, true);
  EXPECT_NE(all.find("2 pair(s)"), std::string::npos) << all;
  EXPECT_NE(all.find("Set pipe_types to the rig's tally"), std::string::npos) << all;
  // A tally the sensor can tell apart: no warning.
  EXPECT_EQ(tallyWarning({tally[1], tally[2]}, false), "");
  EXPECT_EQ(tallyWarning({tally[2]}, true), "");
}
