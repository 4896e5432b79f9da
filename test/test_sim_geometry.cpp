// Ray casting against the simulator's primitives, checked against analytic hits.
#include <gtest/gtest.h>

#include <cmath>

#include "drill_pipe_pose/core/tool_joint.hpp"
#include "drill_pipe_pose/sim/geometry.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"
#include "drill_pipe_pose/sim/scene.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::sim;

namespace {

Ray makeRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  Ray r;
  r.o = o;
  r.d = d.normalized();
  return r;
}

void expectHit(const Shape& s, const Ray& r, double t, const Eigen::Vector3d& n) {
  LocalHit h;
  ASSERT_TRUE(s.intersect(r, 1e-9, 1e9, &h))
      << "ray o=" << r.o.transpose() << " d=" << r.d.transpose();
  EXPECT_NEAR(h.t, t, 1e-9);
  EXPECT_NEAR((h.n - n.normalized()).norm(), 0.0, 1e-9) << "normal " << h.n.transpose();
}

void expectMiss(const Shape& s, const Ray& r) {
  LocalHit h;
  EXPECT_FALSE(s.intersect(r, 1e-9, 1e9, &h)) << "unexpected hit at t=" << h.t;
}

}  // namespace

TEST(SimGeometry, Plane) {
  const Shape inf = Shape::plane(0, 0);
  expectHit(inf, makeRay({0.3, -7, 5}, {0, 0, -1}), 5.0, {0, 0, 1});
  expectHit(inf, makeRay({0, 0, 3}, {0, 4, -3}), 5.0, {0, 0, 1});  // 3-4-5 triangle
  expectMiss(inf, makeRay({0, 0, 3}, {1, 0, 0}));                  // parallel
  expectMiss(inf, makeRay({0, 0, 3}, {0, 0, 1}));                  // away
  const Shape fin = Shape::plane(2, 2);
  expectMiss(fin, makeRay({1.5, 0, 1}, {0, 0, -1}));
  expectHit(fin, makeRay({0.9, 0, 1}, {0, 0, -1}), 1.0, {0, 0, 1});
}

TEST(SimGeometry, Box) {
  const Shape b = Shape::box({2, 2, 2});
  expectHit(b, makeRay({-5, 0.1, 0.2}, {1, 0, 0}), 4.0, {-1, 0, 0});
  expectHit(b, makeRay({0.5, 0.5, 10}, {0, 0, -1}), 9.0, {0, 0, 1});
  expectHit(b, makeRay({0, 0, 0}, {0, 1, 0}), 1.0, {0, 1, 0});  // from inside: exit face
  expectMiss(b, makeRay({-5, 1.5, 0}, {1, 0, 0}));
  // Diagonal onto an edge region: enters through x = -1 at y = 0.5.
  expectHit(b, makeRay({-2, -0.5, 0}, {1, 1, 0}), std::sqrt(2.0), {-1, 0, 0});
}

TEST(SimGeometry, Cylinder) {
  const Shape c = Shape::cylinder(0.5, 0.0, 2.0);
  expectHit(c, makeRay({-3, 0, 1}, {1, 0, 0}), 2.5, {-1, 0, 0});
  expectHit(c, makeRay({0.1, 0.2, 5}, {0, 0, -1}), 3.0, {0, 0, 1});   // top cap
  expectHit(c, makeRay({0.1, 0.2, -1}, {0, 0, 1}), 1.0, {0, 0, -1});  // bottom cap
  expectMiss(c, makeRay({-3, 0, 2.5}, {1, 0, 0}));                    // above
  expectMiss(c, makeRay({-3, 0.6, 1}, {1, 0, 0}));                    // beside
  // Oblique: from (-3, 0, 1) toward (0, 0.3, 1): hits x^2 + y^2 = 0.25.
  const Eigen::Vector3d o(-3, 0, 1), d = Eigen::Vector3d(3, 0.3, 0).normalized();
  // Solve |o + t d|_xy = 0.5.
  const double a = d.head<2>().squaredNorm(), b = 2 * o.head<2>().dot(d.head<2>()),
               cc = o.head<2>().squaredNorm() - 0.25;
  const double t = (-b - std::sqrt(b * b - 4 * a * cc)) / (2 * a);
  const Eigen::Vector3d p = o + t * d;
  expectHit(c, makeRay(o, d), t, Eigen::Vector3d(p.x(), p.y(), 0));
}

TEST(SimGeometry, RevolvedTube) {
  // Tube r in [0.1, 0.2], z in [0, 1], counter-clockwise in (z, r).
  const Shape s = Shape::revolvedProfile({{0, 0.1}, {1, 0.1}, {1, 0.2}, {0, 0.2}});
  expectHit(s, makeRay({-1, 0, 0.5}, {1, 0, 0}), 0.8, {-1, 0, 0});    // outer surface
  expectHit(s, makeRay({0, 0, 0.5}, {1, 0, 0}), 0.1, {-1, 0, 0});     // bore, seen from the axis
  expectHit(s, makeRay({0.15, 0, 5}, {0, 0, -1}), 4.0, {0, 0, 1});    // top annulus
  expectHit(s, makeRay({0, -0.15, -2}, {0, 0, 1}), 2.0, {0, 0, -1});  // bottom annulus
  expectMiss(s, makeRay({0.05, 0, 5}, {0, 0, -1}));                   // straight down the bore
  expectMiss(s, makeRay({-1, 0, 1.5}, {1, 0, 0}));
}

TEST(SimGeometry, RevolvedCone) {
  // Solid frustum: r = 0.2 at z = 0 to r = 0.1 at z = 1.
  const Shape s = Shape::revolvedProfile({{0, 0}, {1, 0}, {1, 0.1}, {0, 0.2}});
  const Eigen::Vector3d n = Eigen::Vector3d(-1, 0, 0.1).normalized();
  expectHit(s, makeRay({-1, 0, 0.5}, {1, 0, 0}), 0.85, n);
  expectHit(s, makeRay({0, 1, 0.25}, {0, -1, 0}), 1.0 - 0.175,
            Eigen::Vector3d(0, 1, 0.1).normalized());
  expectHit(s, makeRay({0.05, 0, 3}, {0, 0, -1}), 2.0, {0, 0, 1});
  // Grazing above the small end misses; the cone's other nappe (z > 2) must not count.
  expectMiss(s, makeRay({-1, 0, 2.5}, {1, 0, 0}));
  // Oblique ray: check the hit lies on the cone surface r = 0.2 - 0.1 z.
  LocalHit h;
  const Ray r = makeRay({-1, 0.05, 1.2}, {1, 0, -0.8});
  ASSERT_TRUE(s.intersect(r, 1e-9, 1e9, &h));
  const Eigen::Vector3d p = r.o + h.t * r.d;
  EXPECT_NEAR(std::hypot(p.x(), p.y()), 0.2 - 0.1 * p.z(), 1e-9);
}

TEST(SimGeometry, ToolJointProfile) {
  for (EndLabel e : {EndLabel::kBoxEnd, EndLabel::kPinEnd}) {
    ToolJointDimensions d;
    const Shape s = Shape::revolvedProfile(toolJointProfile(e, d));
    const double R = d.tool_joint_od / 2;
    // Across the tong, 0.1 m below the shoulder / end face.
    expectHit(s, makeRay({-1, 0, -0.1}, {1, 0, 0}), 1.0 - R, {-1, 0, 0});
    // Across the tube below the taper.
    const double z_tube =
        -(e == EndLabel::kBoxEnd ? d.box_tong_length : d.pin_tong_length) - d.taperLength() - 0.1;
    expectHit(s, makeRay({0, -1, z_tube}, {0, 1, 0}), 1.0 - d.tube_od / 2, {0, -1, 0});
    // On the 18 deg elevator taper: the normal leans 72 deg from the axis toward -z... i.e. the
    // taper faces down-and-out for a joint whose body is below: check it is a unit normal with
    // nz = -sin(18 deg).
    const double z_taper =
        -(e == EndLabel::kBoxEnd ? d.box_tong_length : d.pin_tong_length) - d.taperLength() / 2;
    LocalHit h;
    ASSERT_TRUE(s.intersect(makeRay({-1, 0, z_taper}, {1, 0, 0}), 1e-9, 1e9, &h));
    EXPECT_NEAR(h.n.z(), -std::sin(18.0 * M_PI / 180.0), 1e-9);
    EXPECT_NEAR(h.t, 1.0 - (d.tool_joint_od + d.tube_od) / 4, 1e-9);
  }
}

TEST(SimGeometry, SceneNearestHitAndMud) {
  Scene scene;
  SceneObject floor;
  floor.name = "floor";
  floor.shape = Shape::plane(0, 0);
  floor.material.reflectivity = 0.4;
  scene.objects.push_back(floor);
  SceneObject cyl;
  cyl.name = "cyl";
  cyl.shape = Shape::revolvedProfile({{0, 0}, {1, 0}, {1, 0.2}, {0, 0.2}});
  cyl.material.reflectivity = 0.6;
  MudPatch m;
  m.phi_center = M_PI;  // facing -x
  m.phi_half_width = 0.3;
  m.z_center = 0.5;
  m.z_half_width = 0.1;
  m.reflectivity_factor = 0.25;
  cyl.mud.push_back(m);
  cyl.T_anchor_object.translation() = Eigen::Vector3d(2, 0, 0);
  scene.objects.push_back(cyl);
  const SceneSnapshot snap = scene.snapshot(0.0);
  SceneHit hit;
  ASSERT_TRUE(scene.intersect(makeRay({0, 0, 0.5}, {1, 0, 0}), snap, nullptr, 1e-6, 1e3, &hit));
  EXPECT_EQ(hit.object, 1);
  EXPECT_NEAR(hit.t, 1.8, 1e-9);
  EXPECT_NEAR(hit.reflectivity, 0.15, 1e-6);  // in the mud patch
  ASSERT_TRUE(scene.intersect(makeRay({0, 0, 0.8}, {1, 0, 0}), snap, nullptr, 1e-6, 1e3, &hit));
  EXPECT_NEAR(hit.reflectivity, 0.6, 1e-6);  // above it
  ASSERT_TRUE(scene.intersect(makeRay({0, 0, 3}, {0, 0, -1}), snap, nullptr, 1e-6, 1e3, &hit));
  EXPECT_EQ(hit.object, 0);
  EXPECT_NEAR(hit.t, 3.0, 1e-9);
}

TEST(SimGeometry, TrajectoryLinearSwingAndSequence) {
  Trajectory tr;
  tr.T_world_anchor.translation() = Eigen::Vector3d(1, 2, 3);
  tr.velocity = Eigen::Vector3d(0, 0, -0.2);
  tr.linear_period_s = 5.0;
  EXPECT_NEAR((tr.pose(2.0).translation() - Eigen::Vector3d(1, 2, 2.6)).norm(), 0, 1e-12);
  EXPECT_NEAR((tr.pose(6.0).translation() - Eigen::Vector3d(1, 2, 2.8)).norm(), 0, 1e-12);
  tr.swing_amplitude_rad = 0.1;
  tr.swing_period_s = 4.0;
  tr.swing_pivot_offset = Eigen::Vector3d(0, 0, 4);
  // At t = 1 s the swing is at its amplitude: the anchor is 4 m below the pivot, rotated 0.1 rad.
  const Eigen::Isometry3d T = tr.pose(1.0);
  const Eigen::Vector3d pivot = Eigen::Vector3d(1, 2, 3 - 0.2) + Eigen::Vector3d(0, 0, 4);
  EXPECT_NEAR((T.translation() - pivot).norm(), 4.0, 1e-9);
  EXPECT_NEAR(Eigen::AngleAxisd(T.linear()).angle(), 0.1, 1e-9);
  Trajectory seq;
  seq.pose_sequence.resize(3, Eigen::Isometry3d::Identity());
  for (int i = 0; i < 3; ++i) seq.pose_sequence[i].translation().x() = i;
  seq.pose_interval_s = 2.0;
  EXPECT_EQ(seq.pose(0.5).translation().x(), 0);
  EXPECT_EQ(seq.pose(2.5).translation().x(), 1);
  EXPECT_EQ(seq.pose(7.0).translation().x(), 0);  // cycles
  EXPECT_FALSE(seq.isStatic());
}

TEST(SimPipeType, ALyingPipeStaysOnItsSupport) {
  // catwalk_horizontal with the 3-1/2" NC38 joints: the pipe's axis moves down by the change of
  // the tool-joint radius (the joint still rests on the catwalk); the standing thesis joints do
  // not move.
  const std::string dir = DRILL_PIPE_POSE_SOURCE_DIR;
  sim::SimulatorOptions opt;
  opt.sensor_config_dir = dir + "/config/sensors";
  const auto lowest = [&](const std::string& scene, const std::string& type) {
    opt.pipe_type = type;
    const auto sim = sim::loadScenario(dir + "/config/rigs/thesis_lab.yaml",
                                       dir + "/config/scenes/" + scene + ".yaml", opt);
    const sim::Scene& s = sim->scene();
    const sim::SceneSnapshot snap = s.snapshot(0.0);
    std::vector<double> z;
    for (const sim::SceneEnd& e : s.ends)
      z.push_back(snap.T_world_object[e.object].translation().z() - e.rendered.tool_joint_od / 2);
    return z;
  };
  const std::vector<double> nominal = lowest("catwalk_horizontal", "");
  const std::vector<double> small = lowest("catwalk_horizontal", "3.5in_NC38_4.75od");
  ASSERT_EQ(nominal.size(), small.size());
  ASSERT_FALSE(nominal.empty());
  for (size_t k = 0; k < nominal.size(); ++k)
    EXPECT_NEAR(small[k], nominal[k], 1e-6) << "end " << k << ": the joint's underside moved";
  EXPECT_LT(small[0] + 0.12065 / 2, nominal[0] + ToolJointDimensions().tool_joint_od / 2 - 0.02)
      << "the axis came down by the radius difference (24 mm)";
  const std::vector<double> standing = lowest("thesis_vertical", "3.5in_NC38_4.75od");
  const std::vector<double> standing_nominal = lowest("thesis_vertical", "");
  for (size_t k = 0; k < standing.size(); ++k)
    EXPECT_NEAR(standing[k] + 0.12065 / 2,
                standing_nominal[k] + ToolJointDimensions().tool_joint_od / 2, 1e-6)
        << "end " << k << ": a standing joint moved";
}
