// Labels from 3D poses (core/detector/pose_labels.hpp): the projected box of a known pose against
// a hand computation, occlusion by a wall, the covariance gate, the camera agreement and the pose
// track. Deterministic (no random numbers).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <limits>

#include "drill_pipe_pose/core/detector/pose_labels.hpp"
#include "drill_pipe_pose/core/detector/review_sheet.hpp"
#include "drill_pipe_pose/core/errors.hpp"

using namespace drill_pipe_pose;

namespace {

constexpr double kF = 500.0, kCx = 320.0, kCy = 240.0, kZ = 5.0;

/// A camera at the world origin looking along world z (world = colour optical frame = depth
/// optical frame), 640x480, f = 500 px; the depth image, when given, the same camera.
LabelView view(const DepthImage& depth = DepthImage()) {
  LabelView v;
  v.camera = "cam1";
  v.color = PinholeCamera::fromIntrinsics(640, 480, kF, kF, kCx, kCy);
  v.depth = v.color;
  v.depth_image = depth;
  return v;
}

/// The box end at (0, 0, 5) with its axis along world +x: its box region runs from x = -L to 0.
Eigen::Isometry3d boxEndAlongX() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << 0, 0, 1, 0, 1, 0, -1, 0, 0;  // columns: x_end = -z, y_end = y, z_end = +x
  T.translation() = Eigen::Vector3d(0, 0, kZ);
  return T;
}

/// A 32FC1 depth image with every pixel at `z` [m] (NaN: no reading).
DepthImage flatDepth(float z) {
  DepthImage d = DepthImage::allocate(640, 480, DepthEncoding::kF32Metres);
  for (uint32_t v = 0; v < 480; ++v)
    for (uint32_t u = 0; u < 640; ++u)
      std::memcpy(d.mutableData() + v * d.step + 4 * u, &z, 4);
  return d;
}

void setDepth(DepthImage* d, uint32_t u, uint32_t v, float z) {
  std::memcpy(d->mutableData() + v * d->step + 4 * u, &z, 4);
}

/// The depth image a camera would measure of the model at T (its own nearest surface) in front of
/// a background at `background` [m].
DepthImage modelDepth(const LabelModel& m, const Eigen::Isometry3d& T, float background) {
  DepthImage d = flatDepth(background);
  const PinholeCamera cam = PinholeCamera::fromIntrinsics(640, 480, kF, kF, kCx, kCy);
  for (const OrientedPoint& p : m.points) {
    const Eigen::Vector3d pc = T * p.p.cast<double>();
    Eigen::Vector2d uv;
    if (!cam.project(pc, &uv)) continue;
    const long u = std::lround(uv.x()), v = std::lround(uv.y());
    if (u < 0 || v < 0 || u >= 640 || v >= 480) continue;
    if (pc.z() < d.depthAt(u, v)) setDepth(&d, u, v, static_cast<float>(pc.z()));
  }
  return d;
}

PoseSample tightPose(EndLabel label, const Eigen::Isometry3d& T, int64_t stamp = 1000000000) {
  PoseSample p;
  p.label = label;
  p.stamp_ns = stamp;
  p.T_world_end = T;
  p.covariance.diagonal() << 1e-6, 1e-6, 1e-6, 1e-5, 1e-5, 1e-5;  // 1 mm, 0.18 deg
  p.cameras = 3;
  return p;
}

}  // namespace

TEST(PoseLabels, BoxOfAKnownPoseMatchesTheHandComputation) {
  const ToolJointDimensions d;
  const LabelParams params;
  const LabelModel m = makeLabelModel(EndLabel::kBoxEnd, d, params.point_spacing);
  const EndInView e = projectEnd(m, boxEndAlongX(), view(), params);
  ASSERT_TRUE(e.has_box);
  EXPECT_EQ(e.occluded, 0);
  EXPECT_EQ(e.no_depth, e.in_image);  // no depth image: nothing to compare with
  // The region runs from the end face (x = 0) to the end of the taper (x = -L, tube radius there);
  // the nearest point of the taper's end (z = 5 - r_tube) projects farthest left.
  const double L = d.box_tong_length + d.taperLength();
  const double r_tube = d.tube_od / 2, R = d.tool_joint_od / 2;
  EXPECT_NEAR(e.box.x_min, kCx - kF * L / (kZ - r_tube), 0.5);
  EXPECT_NEAR(e.box.x_max, kCx, 0.5);
  // Top and bottom: the tangents from the eye to the joint's OD circle (radius R at depth 5 m).
  const double half = kF * R / std::sqrt(kZ * kZ - R * R);
  EXPECT_NEAR(e.box.y_min, kCy - half, 0.5);
  EXPECT_NEAR(e.box.y_max, kCy + half, 0.5);
}

TEST(PoseLabels, TheDepthOfTheJointItselfConfirmsThePose) {
  const LabelParams params;
  const LabelModel m = makeLabelModel(EndLabel::kBoxEnd, ToolJointDimensions(), 0.003);
  const EndInView e =
      projectEnd(m, boxEndAlongX(), view(modelDepth(m, boxEndAlongX(), 8.0f)), params);
  EXPECT_GT(e.agreeFraction(), 0.9);
  EXPECT_TRUE(confirmsPose(e, params));
  EXPECT_NEAR(e.visibleFraction(), 1.0, 1e-9);
  // The same depth with the pose 10 cm nearer the camera: the camera sees through it.
  Eigen::Isometry3d off = boxEndAlongX();
  off.translation().z() -= 0.1;
  const EndInView w = projectEnd(m, off, view(modelDepth(m, boxEndAlongX(), 8.0f)), params);
  EXPECT_LT(w.agreeFraction(), 0.1);
  EXPECT_FALSE(confirmsPose(w, params));
}

TEST(PoseLabels, AJointBehindAWallIsNotLabelledAsVisible) {
  const LabelParams params;
  const LabelModel m = makeLabelModel(EndLabel::kBoxEnd, ToolJointDimensions(), 0.003);
  // A wall at 3 m in front of the whole image.
  const EndInView hidden = projectEnd(m, boxEndAlongX(), view(flatDepth(3.0f)), params);
  EXPECT_GT(hidden.in_image, 100);
  EXPECT_EQ(hidden.occluded, hidden.in_image);
  EXPECT_FALSE(hidden.has_box);
  // Through labelImages, two cameras agreeing elsewhere: the image is kept, without a label.
  LabelInputs in;
  in.expected = {{true, false}};
  const PoseSample pose = tightPose(EndLabel::kBoxEnd, boxEndAlongX());
  const EndInView seen =
      projectEnd(m, boxEndAlongX(), view(modelDepth(m, boxEndAlongX(), 8.0f)), params);
  for (const std::string cam : {"cam1", "cam2", "cam3"}) {
    in.cameras.push_back(cam);
    in.stamps_ns.push_back(pose.stamp_ns);
    in.poses.push_back({{pose, std::nullopt}});
    in.projections.push_back({{cam == "cam3" ? hidden : seen, EndInView()}});
  }
  const auto out = labelImages(in, params);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_TRUE(out[0].keep);
  EXPECT_EQ(out[0].labels.size(), 1u);
  EXPECT_TRUE(out[2].keep) << out[2].why;
  EXPECT_TRUE(out[2].labels.empty());
  // A wall over the image's left part (u < 300; the joint spans u = 283-320): the box covers only
  // the visible part.
  DepthImage half = modelDepth(m, boxEndAlongX(), 8.0f);
  for (uint32_t v = 0; v < 480; ++v)
    for (uint32_t u = 0; u < 300; ++u) setDepth(&half, u, v, 3.0f);
  const EndInView part = projectEnd(m, boxEndAlongX(), view(half), params);
  ASSERT_TRUE(part.has_box);
  EXPECT_GT(part.occluded, 0);
  EXPECT_NEAR(part.box.x_min, 299.5, 1.0);
  EXPECT_NEAR(part.box.x_max, kCx, 0.5);
}

TEST(PoseLabels, CovarianceGate) {
  LabelParams params;
  params.max_position_sigma = 0.01;
  params.max_axis_sigma_deg = 1.0;
  PoseSample p = tightPose(EndLabel::kBoxEnd, boxEndAlongX());
  PoseGate g = gatePose(p, params);
  EXPECT_TRUE(g.ok) << g.why;
  EXPECT_NEAR(g.position_sigma, 1e-3, 1e-9);
  // 2 cm along y: too loose.
  p.covariance(1, 1) = 0.02 * 0.02;
  g = gatePose(p, params);
  EXPECT_FALSE(g.ok);
  EXPECT_NE(g.why.find("position sigma"), std::string::npos) << g.why;
  // 2 deg about world y (perpendicular to the end's axis, world x): the axis is loose.
  p = tightPose(EndLabel::kBoxEnd, boxEndAlongX());
  p.covariance(4, 4) = std::pow(2.0 * M_PI / 180, 2);
  g = gatePose(p, params);
  EXPECT_FALSE(g.ok);
  EXPECT_NEAR(g.axis_sigma_deg, 2.0, 1e-6);
  // A large roll (about world x, the end's own axis) is unobservable and does not count.
  p = tightPose(EndLabel::kBoxEnd, boxEndAlongX());
  p.covariance(3, 3) = 1.0;
  EXPECT_TRUE(gatePose(p, params).ok);
  // One camera's points only.
  p = tightPose(EndLabel::kBoxEnd, boxEndAlongX());
  p.cameras = 1;
  EXPECT_FALSE(gatePose(p, params).ok);
  // A person's corrected pose passes.
  p.corrected = true;
  p.covariance.setZero();
  EXPECT_TRUE(gatePose(p, params).ok);
}

TEST(PoseLabels, AnImageNeedsEnoughCamerasToConfirmThePose) {
  const LabelParams params;  // min_agreeing_cameras = 2
  const LabelModel m = makeLabelModel(EndLabel::kBoxEnd, ToolJointDimensions(), 0.003);
  const EndInView seen =
      projectEnd(m, boxEndAlongX(), view(modelDepth(m, boxEndAlongX(), 8.0f)), params);
  const EndInView unseen;  // not in the other camera's image
  LabelInputs in;
  in.expected = {{true, false}};
  const PoseSample pose = tightPose(EndLabel::kBoxEnd, boxEndAlongX());
  for (const std::string cam : {"cam1", "cam2"}) {
    in.cameras.push_back(cam);
    in.stamps_ns.push_back(pose.stamp_ns);
    in.poses.push_back({{pose, std::nullopt}});
    in.projections.push_back({{cam == "cam1" ? seen : unseen, EndInView()}});
  }
  auto out = labelImages(in, params);
  EXPECT_FALSE(out[0].keep);
  EXPECT_NE(out[0].why.find("confirmed by 1"), std::string::npos) << out[0].why;
  // A second camera 40 ms later is another moment; at 10 ms it is the same.
  in.projections[1][0] = seen;
  in.stamps_ns[1] = pose.stamp_ns + 40000000;
  EXPECT_FALSE(labelImages(in, params)[0].keep);
  in.stamps_ns[1] = pose.stamp_ns + 10000000;
  out = labelImages(in, params);
  EXPECT_TRUE(out[0].keep) << out[0].why;
  ASSERT_EQ(out[0].labels.size(), 1u);
  EXPECT_EQ(out[0].labels[0].id, "cam1_1000000000_box_end");
  EXPECT_LT(out[0].labels[0].doubt, kDefaultReviewDoubt);
  // No pose for an end the recording holds: the image is left out.
  in.expected = {{true, true}};
  EXPECT_FALSE(labelImages(in, params)[0].keep);
}

TEST(PoseLabels, PoseTrackInterpolates) {
  PoseTrack t;
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = a;
  b.translation() = Eigen::Vector3d(0.1, 0, 0);
  b.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  PoseSample s = tightPose(EndLabel::kPinEnd, a, 1000000000);
  t.add(s);
  s = tightPose(EndLabel::kPinEnd, b, 1040000000);
  s.covariance(0, 0) = 4e-6;
  t.add(s);
  const auto mid = t.at(1010000000, 0.1);
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->T_world_end.translation().x(), 0.025, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(mid->T_world_end.linear()).angle(), 0.05, 1e-9);
  EXPECT_DOUBLE_EQ(mid->covariance(0, 0), 4e-6);
  EXPECT_TRUE(mid->T_prev.isApprox(a));  // the estimates around it, for the doubt's spread
  EXPECT_TRUE(mid->T_next.isApprox(b));
  EXPECT_FALSE(t.at(900000000, 0.1));  // 100 ms before the first: more than half the gap
  EXPECT_TRUE(t.at(1060000000, 0.1));  // 20 ms after the last: the nearest
}

TEST(PoseLabels, DoubtIsMeasured) {
  // The spread: the box end along x at 5 m moved 10 mm across the view between the estimates
  // around the pose: 500 px/m * 0.01 m = 1 px at both axis end points.
  const LabelModel m = makeLabelModel(EndLabel::kBoxEnd, ToolJointDimensions(), 0.003);
  PoseSample p = tightPose(EndLabel::kBoxEnd, boxEndAlongX());
  p.T_prev = p.T_next = p.T_world_end;
  EXPECT_DOUBLE_EQ(poseSpreadPx(m, p, view()), 0.0);
  p.T_next.translation().y() += 0.01;
  EXPECT_NEAR(poseSpreadPx(m, p, view()), 1.0, 1e-9);
  // The parts: this camera's see-through share, the measuring cameras that do not confirm, the
  // spread over the box's smaller side.
  LabelItem item;
  item.box.x_min = 100;
  item.box.x_max = 200;
  item.box.y_min = 50;
  item.box.y_max = 90;  // 40 px high
  item.agree_fraction = 0.9;
  item.agreeing_cameras = 3;
  item.measured_cameras = 4;
  item.spread_px = 8;
  const DoubtParts d = doubtParts(item);
  EXPECT_NEAR(d.disagree, 0.1, 1e-12);
  EXPECT_NEAR(d.unconfirmed, 0.25, 1e-12);
  EXPECT_NEAR(d.spread, 0.2, 1e-12);
  EXPECT_NEAR(labelDoubt(item, LabelParams()), 0.2, 1e-12);  // the spread (see labelDoubt)
  item.measured_cameras = 0;  // nobody measures it
  EXPECT_DOUBLE_EQ(doubtParts(item).unconfirmed, 1.0);
  item.corrected = true;
  EXPECT_DOUBLE_EQ(labelDoubt(item, LabelParams()), 0.0);
}

TEST(PoseLabels, CorrectionsAndRejectionsFiles) {
  const std::string dir = ::testing::TempDir();
  const std::string c = dir + "/corrections.yaml", r = dir + "/rejected.yaml";
  {
    std::ofstream f(c);
    f << "corrections:\n  - {stamp: 1.5, end: pin_end, translation: [1, 2, 3], "
         "rotation: [0, 0, 0, 1]}\n";
    std::ofstream g(r);
    g << "rejected:\n  - cam1_1_box_end\n";
  }
  const auto cs = loadCorrections(c);
  ASSERT_EQ(cs.size(), 1u);
  EXPECT_EQ(cs[0].stamp_ns, 1500000000);
  EXPECT_EQ(cs[0].label, EndLabel::kPinEnd);
  EXPECT_TRUE(cs[0].corrected);
  EXPECT_EQ(loadRejected(r), std::set<std::string>{"cam1_1_box_end"});
  {
    std::ofstream f(c);
    f << "corrections:\n  - {stamp: 1.5, end: elbow, translation: [1, 2, 3], "
         "rotation: [0, 0, 0, 1]}\n";
  }
  try {
    loadCorrections(c);
    FAIL() << "an unknown end was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("entry 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("elbow"), std::string::npos) << e.what();
  }
}
