// Tool-joint geometry: profile validity, surface sampling, mesh orientation, pipe-end frames.
#include <gtest/gtest.h>

#include <cmath>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

using namespace drill_pipe_pose;

namespace {

// Signed area of a polygon in (z, r): > 0 for counter-clockwise.
double signedArea(const std::vector<ProfilePoint>& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const auto& u = p[i];
    const auto& v = p[(i + 1) % p.size()];
    a += u.z * v.r - v.z * u.r;
  }
  return a / 2;
}

// Volume of the solid of revolution (Pappus): 2 pi * area * centroid radius.
double volume(const std::vector<ProfilePoint>& p) {
  double v = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const auto& a = p[i];
    const auto& b = p[(i + 1) % p.size()];
    v += (a.z * b.r - b.z * a.r) * (a.r + b.r);
  }
  return 2 * M_PI * v / 6;
}

}  // namespace

TEST(ToolJoint, ProfilesAreCounterClockwiseWithPositiveRadius) {
  for (bool threads : {false, true})
    for (EndLabel e : {EndLabel::kBoxEnd, EndLabel::kPinEnd}) {
      ToolJointDimensions d;
      d.threads = threads;
      const auto p = toolJointProfile(e, d);
      EXPECT_GT(signedArea(p), 0.0) << labelName(e);
      EXPECT_GT(volume(p), 0.0) << labelName(e);
      for (const auto& q : p) EXPECT_GT(q.r, 0.0);
    }
}

TEST(ToolJoint, FramesFollowTheConvention) {
  const ToolJointDimensions d;
  // Box: everything at z <= 0 (the mate comes from +z); the end face annulus is at z = 0.
  double zmax = -1, zmin = 1;
  for (const auto& q : toolJointProfile(EndLabel::kBoxEnd, d)) {
    zmax = std::max(zmax, q.z);
    zmin = std::min(zmin, q.z);
  }
  EXPECT_DOUBLE_EQ(zmax, 0.0);
  EXPECT_NEAR(zmin, -(d.box_tong_length + d.taperLength() + d.tube_length), 1e-12);
  // Pin: the nose is at +pin_length, the shoulder at 0 with the full tool-joint OD just below.
  zmax = -1;
  bool shoulder = false;
  for (const auto& q : toolJointProfile(EndLabel::kPinEnd, d)) {
    zmax = std::max(zmax, q.z);
    if (q.z == 0.0 && std::abs(q.r - d.tool_joint_od / 2) < 1e-12) shoulder = true;
  }
  EXPECT_DOUBLE_EQ(zmax, d.pin_length);
  EXPECT_TRUE(shoulder);
  EXPECT_NEAR(d.taperLength(), (0.168275 - 0.127) / 2 / std::tan(18 * M_PI / 180), 1e-12);
}

TEST(ToolJoint, SampledSurfaceLiesOnTheProfileWithOutwardNormals) {
  const ToolJointDimensions d;
  const auto profile = toolJointProfile(EndLabel::kPinEnd, d);
  const auto pts = sampleProfileSurface(profile, 0.005, 1);
  ASSERT_GT(pts.size(), 1000u);
  for (const auto& op : pts) {
    // Every point is on some edge of the profile (distance in the (z, r) plane ~ 0).
    const double z = op.p.z(), r = std::hypot(op.p.x(), op.p.y());
    double best = 1e9;
    for (size_t i = 0; i < profile.size(); ++i) {
      const Eigen::Vector2d a(profile[i].z, profile[i].r);
      const Eigen::Vector2d b(profile[(i + 1) % profile.size()].z,
                              profile[(i + 1) % profile.size()].r);
      const Eigen::Vector2d q(z, r);
      const double s = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      best = std::min(best, (a + s * (b - a) - q).norm());
    }
    ASSERT_LT(best, 1e-5) << "point " << op.p.transpose();
    ASSERT_NEAR(op.n.norm(), 1.0f, 1e-5f);
  }
  // Outer-only drops the bore.
  const auto outer = sampleProfileSurface(profile, 0.005, 1, true);
  EXPECT_LT(outer.size(), pts.size());
  for (const auto& op : outer)
    EXPECT_GE(op.n.x() * op.p.x() + op.n.y() * op.p.y(), -1e-6f) << op.p.transpose();
}

TEST(ToolJoint, SamplingIsUniformByArea) {
  // The outer tong cylinder and the shoulder annulus get points in proportion to their areas.
  const ToolJointDimensions d;
  const auto pts = sampleProfileSurface(toolJointProfile(EndLabel::kPinEnd, d), 0.003, 2);
  const double R = d.tool_joint_od / 2, Rl = d.pin_large_diameter / 2;
  size_t tong = 0, shoulder = 0;
  for (const auto& op : pts) {
    const double r = std::hypot(op.p.x(), op.p.y());
    if (std::abs(r - R) < 1e-6 && op.p.z() < 0 && op.p.z() > -d.pin_tong_length) ++tong;
    if (std::abs(op.p.z()) < 1e-9 && r > Rl && r < R) ++shoulder;
  }
  const double area_tong = 2 * M_PI * R * d.pin_tong_length;
  const double area_shoulder = M_PI * (R * R - Rl * Rl);
  EXPECT_NEAR(static_cast<double>(tong) / shoulder, area_tong / area_shoulder,
              0.1 * area_tong / area_shoulder);
}

TEST(ToolJoint, MeshTrianglesFaceOutward) {
  const auto profile = toolJointProfile(EndLabel::kBoxEnd, ToolJointDimensions());
  const TriangleMesh m = revolveProfile(profile, 48);
  EXPECT_EQ(m.triangles.size(), profile.size() * 48 * 2);
  // Divergence theorem: the signed volume of a closed outward mesh equals the solid's volume.
  double v = 0;
  for (const auto& t : m.triangles)
    v += m.vertices[t[0]].cast<double>().dot(
             m.vertices[t[1]].cast<double>().cross(m.vertices[t[2]].cast<double>())) /
         6;
  EXPECT_NEAR(v, volume(profile), 0.01 * volume(profile));
}

TEST(ToolJoint, BadDimensionsAreNamed) {
  ToolJointDimensions d;
  d.tube_od = 0.2;
  try {
    toolJointProfile(EndLabel::kBoxEnd, d);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field tube_od = 0.2 must be < tool_joint_od = 0.168275"),
              std::string::npos)
        << e.what();
  }
  d = ToolJointDimensions();
  d.pin_length = -1;
  EXPECT_THROW(toolJointProfile(EndLabel::kPinEnd, d), InputError);
}

TEST(PipeEndFrame, CanonicalRollFollowsTheConvention) {
  // Vertical axis: x is world x.
  Eigen::Matrix3d R = canonicalRotation(Eigen::Vector3d(0, 0, 2));
  EXPECT_TRUE(R.isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  // Axis along world x: x falls back to world y.
  R = canonicalRotation(Eigen::Vector3d(1, 0, 0));
  EXPECT_TRUE(R.col(0).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  // Any axis: a proper rotation with z along the axis; roll independent of the input roll.
  const Eigen::Vector3d z = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  R = canonicalRotation(z);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE((R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_TRUE(R.col(2).isApprox(z, 1e-12));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R * Eigen::AngleAxisd(1.234, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(canonicalize(T).linear().isApprox(R, 1e-12));
}

TEST(PipeEndFrame, PinInBoxOfAStandOverItsStump) {
  // A stand's pin 0.36 m above a stump's box face, 3 cm to the side, hanging 2 deg off plumb:
  // the pose and the origin-and-axis forms agree, whatever the roll.
  const Eigen::Vector3d box_o(4.694, 6.05, 0.8), pin_o(4.724, 6.05, 1.164);
  const Eigen::Vector3d box_z = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d pin_z =
      Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) * -Eigen::Vector3d::UnitZ();
  const PinInBoxRelation r = pinInBox(box_o, box_z, pin_o, pin_z);
  EXPECT_NEAR(r.axial_standoff, 0.364, 1e-9);
  EXPECT_NEAR(r.lateral_offset, 0.03, 1e-9);
  EXPECT_NEAR(r.axis_angle, 2.0 * M_PI / 180.0, 1e-9);
  Eigen::Isometry3d T_box = canonicalPose(box_o, box_z), T_pin = canonicalPose(pin_o, pin_z);
  T_box.linear() =
      T_box.linear() * Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const PinInBoxRelation q = pinInBox(T_box, T_pin);
  EXPECT_NEAR(q.axial_standoff, r.axial_standoff, 1e-12);
  EXPECT_NEAR(q.lateral_offset, r.lateral_offset, 1e-12);
  EXPECT_NEAR(q.axis_angle, r.axis_angle, 1e-12);
}
