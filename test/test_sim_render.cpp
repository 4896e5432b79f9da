// Rendering, sensor model, simulated detector, schedule, scenario files.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numeric>
#include <sstream>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "drill_pipe_pose/sim/depth_effects.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::sim;

namespace {

const std::string kSource = DRILL_PIPE_POSE_SOURCE_DIR;
const std::string kRig = kSource + "/config/rigs/thesis_lab.yaml";
std::string scenePath(const std::string& name) {
  return kSource + "/config/scenes/" + name + ".yaml";
}

/// A camera at `eye` looking at `target` (optical frame: z forward, x right, y down).
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ());
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();
  x.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = z.cross(x);
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

RigCalibration oneCameraRig(const Eigen::Isometry3d& T_world_link) {
  RigCalibration rig;
  CameraCalibration c;
  c.name = "cam1";
  c.T_world_link = T_world_link;
  rig.cameras.push_back(c);
  return rig;
}

/// A scene with a wall (plane) perpendicular to world x at x = d, facing -x.
SceneConfig wallScene(double d, const std::string& material) {
  std::ostringstream s;
  s << "name: wall\nwork_zone: {min: [0, -1, -1], max: [10, 1, 1]}\n"
    << "materials: {grey70: {reflectivity: 0.7, bgr: [128, 128, 128]},"
    << " black05: {reflectivity: 0.05, bgr: [20, 20, 20]}}\n"
    << "objects:\n  - {name: wall, type: plane, size: [0, 0], material: " << material
    << ", pose: {translation: [" << d << ", 0, 0], z_axis: [-1, 0, 0]}}\n"
    << "pipes:\n  - {name: p, type: tool_joint, end: box_end, material: yellow_paint,"
    << " pose: {translation: [0, 0, -50], rpy_deg: [0, 0, 0]}}\n";
  return parseSceneConfig(s.str(), "wall scene");
}

std::vector<uint8_t> bytesOf(const DepthImage& img) {
  return std::vector<uint8_t>(img.data.get(), img.data.get() + img.size);
}

/// Distance [m] from (z, r) to the closed profile polygon.
double distanceToProfile(const std::vector<ProfilePoint>& prof, double z, double r) {
  double best = 1e9;
  for (size_t i = 0; i < prof.size(); ++i) {
    const Eigen::Vector2d a(prof[i].z, prof[i].r);
    const Eigen::Vector2d b(prof[(i + 1) % prof.size()].z, prof[(i + 1) % prof.size()].r);
    const Eigen::Vector2d p(z, r), ab = b - a;
    const double s = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-18), 0.0, 1.0);
    best = std::min(best, (a + s * ab - p).norm());
  }
  return best;
}

SensorEffects onlyAxialNoise() {
  SensorEffects fx = sensorProfile("ideal");
  fx.axial_noise = true;
  fx.quantisation = true;
  return fx;
}

}  // namespace

TEST(SimRender, IdealPlaneAtExactDepth) {
  // Camera 5 m above an infinite floor looking straight down.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0, 0, 5);
  const SceneConfig scene = parseSceneConfig(
      "name: floor\nwork_zone: {min: [-1, -1, 0], max: [1, 1, 1]}\n"
      "objects: [{name: floor, type: plane, size: [0, 0], material: concrete,"
      " pose: {translation: [0, 0, 0], rpy_deg: [0, 0, 0]}}]\n"
      "pipes: [{name: p, type: tool_joint, end: pin_end, pose: {translation: [50, 50, 0.3],"
      " rpy_deg: [0, 0, 0]}}]\n",
      "floor scene");
  SimulatorOptions opt;
  opt.profile = "ideal";
  opt.simulated_detection = false;
  RigSimulator sim(oneCameraRig(T), scene, opt);
  const RigSimulator::Frame f = sim.render(0, 0.0, 0);
  const DepthImage& d = f.sensor_frame.depth;
  ASSERT_EQ(d.encoding, DepthEncoding::kF32Metres);  // ideal: unquantised
  ASSERT_EQ(d.width, 512u);
  ASSERT_EQ(d.height, 424u);
  // The depth camera sits T_link_depth away: 1 mm behind the colour camera along the optical
  // axis, i.e. 1 mm higher: every depth is 5.001 m.
  const double expected = 5.0 - sim.T_link_depth(0).translation().z();
  EXPECT_NEAR(expected, 5.001, 1e-9);
  double max_err = 0;
  for (uint32_t v = 0; v < d.height; ++v)
    for (uint32_t u = 0; u < d.width; ++u)
      max_err = std::max(max_err, std::abs(d.depthAt(u, v) - expected));
  EXPECT_LT(max_err, 2e-6);
  EXPECT_EQ(f.sensor_frame.frame_id, "cam1_rgb_optical_frame");
  EXPECT_EQ(f.sensor_frame.depth_frame_id, "cam1_ir_optical_frame");
  EXPECT_EQ(f.sensor_frame.depth_info.frame_id, "cam1_ir_optical_frame");
  EXPECT_EQ(f.sensor_frame.color_info.width, 960u);
}

TEST(SimRender, TfDirectionOfColorToDepth) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  SimulatorOptions opt;
  RigSimulator sim(loadRigCalibration(kRig), scene, opt);
  // TF <cam>_rgb_optical_frame -> <cam>_ir_optical_frame: the IR origin in the colour frame.
  EXPECT_NEAR(sim.T_link_depth(0).translation().x(), -0.0515, 1e-9);
  EXPECT_NEAR(sim.T_link_depth(0).translation().z(), -0.001, 1e-9);
  // A world point lands on consistent pixels: registering its depth pixel into the colour image
  // (core DepthToColorRegistration with T_link_depth) gives its colour projection.
  const PinholeCamera depth = PinholeCamera::fromCameraInfo(sim.depthInfo(0), "depth");
  const PinholeCamera color = PinholeCamera::fromCameraInfo(sim.colorInfo(0), "color");
  const DepthToColorRegistration reg(depth, color, sim.T_link_depth(0));
  const Eigen::Vector3d p_world(4.694, 5.3, 0.2);
  const Eigen::Isometry3d T_link_world = sim.trueT_world_link(0).inverse();
  const Eigen::Vector3d p_depth = sim.T_link_depth(0).inverse() * (T_link_world * p_world);
  Eigen::Vector2d uv_d, uv_c, uv_reg;
  ASSERT_TRUE(depth.project(p_depth, &uv_d));
  ASSERT_TRUE(color.project(T_link_world * p_world, &uv_c));
  ASSERT_TRUE(reg.registerPixel(uv_d.x(), uv_d.y(), p_depth.z(), &uv_reg));
  EXPECT_NEAR((uv_reg - uv_c).norm(), 0.0, 1e-6);
}

TEST(SimRender, IdealToolJointBackProjectsOntoModel) {
  for (EndLabel label : {EndLabel::kBoxEnd, EndLabel::kPinEnd}) {
    std::ostringstream s;
    s << "name: tj\nwork_zone: {min: [-1, -1, 0], max: [1, 1, 2]}\n"
      << "room: {size: [20, 20, 6]}\n"
      << "pipes: [{name: p, type: tool_joint, end: " << labelName(label)
      << ", pose: {translation: [10, 10, 0.8], rpy_deg: [0, 0, 0]}}]\n";
    const SceneConfig scene = parseSceneConfig(s.str(), "tool joint scene");
    // 5.5 m away, 3 m up.
    const Eigen::Isometry3d T = lookAt({10 - 4.6, 10 - 1.0, 3.0}, {10, 10, 0.6});
    SimulatorOptions opt;
    opt.profile = "ideal";
    opt.simulated_detection = false;
    RigSimulator sim(oneCameraRig(T), scene, opt);
    const RigSimulator::Frame f = sim.render(0, 0.0, 0);
    const PinholeCamera depth = PinholeCamera::fromCameraInfo(f.sensor_frame.depth_info, "d");
    const DepthProjector proj(depth);
    const Eigen::Isometry3d T_end_depth =
        sim.scene().endPose(0, 0.0).inverse() * sim.trueT_world_link(0) * sim.T_link_depth(0);
    const std::vector<ProfilePoint> prof = toolJointProfile(label, ToolJointDimensions());
    int n = 0;
    double max_d = 0;
    for (const Eigen::Vector3f& p : proj.allPoints(f.sensor_frame.depth)) {
      const Eigen::Vector3d q = T_end_depth * p.cast<double>();
      const double r = q.head<2>().norm();
      if (r > 0.1 || q.z() < -0.75) continue;  // floor / walls
      ++n;
      max_d = std::max(max_d, distanceToProfile(prof, q.z(), r));
    }
    EXPECT_GT(n, 200) << labelName(label);
    EXPECT_LT(max_d, 1e-3) << labelName(label) << ": " << n << " points";
  }
}

TEST(SimRender, AxialNoiseMatchesFankhauser) {
  for (double dist : {1.0, 3.0, 5.0, 7.0}) {
    SimulatorOptions opt;
    opt.seed = 42;
    opt.simulated_detection = false;
    opt.effects = onlyAxialNoise();
    RigSimulator sim(oneCameraRig(lookAt({0, 0, 0}, {1, 0, 0})), wallScene(dist, "grey70"), opt);
    double sum2 = 0, sum2_expected = 0;
    int n = 0;
    const PinholeCamera cam = sim.sensor(0).depth;
    for (uint64_t k = 0; k < 8; ++k) {
      const RigSimulator::Frame f = sim.render(0, k / 30.0, k);
      const DepthImage& d = f.sensor_frame.depth;
      for (uint32_t v = 162; v < 252; ++v)
        for (uint32_t u = 210; u < 310; ++u) {
          const float z = d.depthAt(u, v);
          ASSERT_TRUE(z == z);
          // The wall is perpendicular to the optical axis: the true depth is the same everywhere.
          const double zt =
              dist - (sim.trueT_world_link(0) * sim.T_link_depth(0)).translation().x();
          const Eigen::Vector3d ray((u - cam.cx()) / cam.fx(), (v - cam.cy()) / cam.fy(), 1.0);
          const double theta = std::acos(1.0 / ray.norm());
          sum2 += (z - zt) * (z - zt);
          const double s = axialNoiseSigma(zt, theta);
          sum2_expected += s * s + 1e-6 / 12.0;  // + 1 mm quantisation
          ++n;
        }
    }
    const double sigma = std::sqrt(sum2 / n), expected = std::sqrt(sum2_expected / n);
    std::printf("[ noise    ] %.0f m: simulated sigma %.2f mm, Fankhauser %.2f mm (%d px)\n", dist,
                sigma * 1e3, expected * 1e3, n);
    EXPECT_NEAR(sigma / expected, 1.0, 0.10) << "distance " << dist << " seed " << opt.seed;
  }
  // The formula itself: ~6.5 mm at 5 m, ~12.7 mm at 7 m head-on (Fankhauser et al. 2015).
  EXPECT_NEAR(axialNoiseSigma(5.0, 0.0) * 1e3, 6.5, 0.05);
  EXPECT_NEAR(axialNoiseSigma(7.0, 0.0) * 1e3, 12.7, 0.05);
}

TEST(SimRender, DropoutGrowsWithDistanceAndDarkness) {
  auto invalidFraction = [](double dist, const std::string& mat) {
    SimulatorOptions opt;
    opt.seed = 3;
    opt.simulated_detection = false;
    SensorEffects fx = sensorProfile("ideal");
    fx.dropout = true;
    fx.max_range = 12.0;
    opt.effects = fx;
    RigSimulator sim(oneCameraRig(lookAt({0, 0, 0}, {1, 0, 0})), wallScene(dist, mat), opt);
    const DepthImage d = sim.render(0, 0.0, 0).sensor_frame.depth;
    int bad = 0, n = 0;
    for (uint32_t v = 112; v < 312; ++v)
      for (uint32_t u = 156; u < 356; ++u, ++n) bad += !(d.depthAt(u, v) == d.depthAt(u, v));
    return static_cast<double>(bad) / n;
  };
  const double grey3 = invalidFraction(3.0, "grey70"), grey7 = invalidFraction(7.0, "grey70");
  const double black2 = invalidFraction(2.0, "black05"), black4 = invalidFraction(4.0, "black05"),
               black6 = invalidFraction(6.0, "black05");
  std::printf("[ dropout  ] grey 3 m %.3f, 7 m %.3f; black 2 m %.3f, 4 m %.3f, 6 m %.3f\n", grey3,
              grey7, black2, black4, black6);
  EXPECT_LT(grey7, 0.01);
  EXPECT_LT(grey3, 0.01);
  EXPECT_LT(black2, 0.01);
  EXPECT_GT(black4, 0.1);  // amplitude 0.05 / 16 is inside the dropout ramp
  EXPECT_GT(black6, 0.99);
  EXPECT_LT(black2, black4);
  EXPECT_LT(black4, black6);
  EXPECT_LE(grey3, black2 + 0.01);
}

TEST(SimRender, FlyingPixelsOnlyAtDepthEdges) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  SimulatorOptions ideal_opt;
  ideal_opt.profile = "ideal";
  ideal_opt.simulated_detection = false;
  SimulatorOptions fly_opt = ideal_opt;
  SensorEffects fx = sensorProfile("ideal");
  fx.flying_pixels = true;
  fx.flying_probability = 1.0;
  fly_opt.effects = fx;
  const RigCalibration rig = loadRigCalibration(kRig);
  RigSimulator a(rig, scene, ideal_opt), b(rig, scene, fly_opt);
  const DepthImage da = a.render(0, 0.0, 0).sensor_frame.depth;
  const DepthImage db = b.render(0, 0.0, 0).sensor_frame.depth;
  int changed = 0, changed_off_edge = 0;
  for (uint32_t v = 1; v + 1 < da.height; ++v)
    for (uint32_t u = 1; u + 1 < da.width; ++u) {
      const float z = da.depthAt(u, v), zb = db.depthAt(u, v);
      if (!(z == z) || std::abs(z - zb) < 1e-6) continue;
      ++changed;
      float jump = 0;
      for (auto [du, dv] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
        const float zn = da.depthAt(u + du, v + dv);
        if (zn == zn) jump = std::max(jump, std::abs(zn - z));
      }
      if (jump <= fx.flying_jump) ++changed_off_edge;
    }
  std::printf("[ flying   ] %d pixels mixed, %d not at an edge\n", changed, changed_off_edge);
  EXPECT_GT(changed, 20);
  EXPECT_EQ(changed_off_edge, 0);
}

TEST(SimRender, SensorParametersSetByNameWithinTheirRange) {
  SensorEffects fx = sensorProfile("kinect_v2_calibrated");
  setEffectParameter(&fx, "lateral_noise_px=0.25");
  EXPECT_DOUBLE_EQ(fx.lateral_noise_px, 0.25);
  setEffectParameter(&fx, "flying_amplitude_weighted", 0.0);
  EXPECT_FALSE(fx.flying_amplitude_weighted);
  for (const char* bad : {"lateral=1", "flying_probability=1.5", "flying_probability=x",
                          "=0.3", "flying_amplitude_weighted=0.5"}) {
    try {
      setEffectParameter(&fx, std::string(bad));
      ADD_FAILURE() << bad << " must be refused";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string(bad).substr(0, 5)), std::string::npos)
          << e.what();
    }
  }
}

TEST(SimRender, DeterministicForSeedAndOrderIndependent) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  const RigCalibration rig = loadRigCalibration(kRig);
  SimulatorOptions opt;
  opt.profile = "kinect_v2_field";
  opt.seed = 7;
  opt.color = true;
  RigSimulator a(rig, scene, opt), b(rig, scene, opt);
  const RigSimulator::Frame a2 = a.render(2, 0.1, 3);
  const RigSimulator::Frame a1 = a.render(1, 0.0, 0);
  const RigSimulator::Frame b1 = b.render(1, 0.0, 0);
  const RigSimulator::Frame b2 = b.render(2, 0.1, 3);
  EXPECT_EQ(bytesOf(a1.sensor_frame.depth), bytesOf(b1.sensor_frame.depth)) << "seed 7";
  EXPECT_EQ(bytesOf(a2.sensor_frame.depth), bytesOf(b2.sensor_frame.depth)) << "seed 7";
  EXPECT_EQ(a2.bgr, b2.bgr);
  ASSERT_EQ(a2.sensor_frame.boxes.size(), b2.sensor_frame.boxes.size());
  for (size_t i = 0; i < a2.sensor_frame.boxes.size(); ++i)
    EXPECT_EQ(
        std::memcmp(&a2.sensor_frame.boxes[i], &b2.sensor_frame.boxes[i], sizeof(DetectionBox)), 0);
  EXPECT_EQ(a.publishedT_world_link(3).matrix(), b.publishedT_world_link(3).matrix());
  // Another frame or seed differs.
  EXPECT_NE(bytesOf(a.render(1, 0.0, 1).sensor_frame.depth), bytesOf(a1.sensor_frame.depth));
  opt.seed = 8;
  RigSimulator c(rig, scene, opt);
  EXPECT_NE(bytesOf(c.render(1, 0.0, 0).sensor_frame.depth), bytesOf(a1.sensor_frame.depth));
}

TEST(SimRender, FieldProfileInjectsCalibrationError) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  const RigCalibration rig = loadRigCalibration(kRig);
  SimulatorOptions opt;
  opt.profile = "kinect_v2_field";
  RigSimulator field(rig, scene, opt);
  opt.profile = "kinect_v2_calibrated";
  RigSimulator cal(rig, scene, opt);
  for (size_t i = 0; i < field.numCameras(); ++i) {
    const Eigen::Isometry3d d =
        field.trueT_world_link(i).inverse() * field.publishedT_world_link(i);
    EXPECT_NEAR(d.translation().norm(), 0.005, 1e-9);
    EXPECT_NEAR(Eigen::AngleAxisd(d.linear()).angle(), 0.2 * M_PI / 180, 1e-9);
    EXPECT_TRUE(cal.publishedT_world_link(i).isApprox(rig.cameras[i].T_world_link));
    EXPECT_LE(std::abs(cal.depthOffset(i)), 0.005);
    EXPECT_LE(std::abs(field.depthOffset(i)), 0.010);
  }
}

TEST(SimRender, WornJointsDifferFromNominal) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  SimulatorOptions opt;
  RigSimulator sim(loadRigCalibration(kRig), scene, opt);
  for (const SceneEnd& e : sim.scene().ends) {
    const double od = e.nominal.tool_joint_od - e.rendered.tool_joint_od;
    EXPECT_GT(od, 0.0);
    EXPECT_LE(od, 0.002);
    const double tong = e.label == EndLabel::kBoxEnd
                            ? e.nominal.box_tong_length - e.rendered.box_tong_length
                            : e.nominal.pin_tong_length - e.rendered.pin_tong_length;
    EXPECT_GT(tong, 0.0);
    EXPECT_LE(tong, 0.020);
    EXPECT_FALSE(sim.scene().objects[e.object].mud.empty());
  }
}

TEST(SimRender, CaptureScheduleUnsynchronised30Hz) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  SimulatorOptions opt;
  opt.seed = 5;
  RigSimulator sim(loadRigCalibration(kRig), scene, opt);
  const auto sched = sim.captureSchedule(0.0, 10.0);
  const auto caps = sim.captures(0.0, 10.0);
  ASSERT_EQ(sched.size(), caps.size());
  for (size_t i = 1; i < sched.size(); ++i) ASSERT_LE(sched[i - 1].first, sched[i].first);
  std::vector<double> first(sim.numCameras(), -1);
  for (size_t c = 0; c < sim.numCameras(); ++c) {
    std::vector<double> t;
    for (const auto& s : sched)
      if (s.second == c) t.push_back(s.first);
    EXPECT_NEAR(static_cast<double>(t.size()), 300.0, 1.0) << "camera " << c << " seed 5";
    const double mean_dt = (t.back() - t.front()) / (t.size() - 1);
    EXPECT_NEAR(mean_dt, 1.0 / 30.0, 2e-4);
    first[c] = t.front();
    for (double x : t) ASSERT_GE(x, 0.0);
  }
  // Distinct phases.
  std::sort(first.begin(), first.end());
  for (size_t c = 1; c < first.size(); ++c) EXPECT_GT(first[c] - first[c - 1], 1e-5);
  // captureTime agrees with the schedule, frame indices count up per camera.
  for (const Capture& c : caps) EXPECT_DOUBLE_EQ(sim.captureTime(c.camera, c.frame_index), c.t);
  // A window in the middle returns the same captures as the full one.
  const auto mid = sim.captures(3.0, 3.5);
  size_t n = 0;
  for (const Capture& c : caps) n += (c.t >= 3.0 && c.t < 3.5);
  EXPECT_EQ(mid.size(), n);
}

TEST(SimDetector, BoxContainsProjectedToolJoint) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  SimulatorOptions opt;
  opt.profile = "ideal";
  RigSimulator sim(loadRigCalibration(kRig), scene, opt);
  const SceneSnapshot snap = sim.scene().snapshot(0.0);
  int checked = 0;
  for (size_t c = 0; c < sim.numCameras(); ++c) {
    const PinholeCamera color = sim.sensor(c).color;
    const Eigen::Isometry3d T_world_color = sim.trueT_world_link(c);
    const auto regions = sim.detector().visibleRegions(sim.scene(), snap, color, T_world_color);
    for (const VisibleRegion& r : regions) {
      const SceneEnd& e = sim.scene().ends[r.end];
      const Eigen::Isometry3d T_world_end = sim.scene().endPose(r.end, 0.0);
      // Visible surface points of the region project inside the box: sample the outer surface
      // above the floor facing the camera.
      const std::vector<ProfilePoint> prof = toolJointProfile(e.label, e.rendered);
      int inside = 0, total = 0;
      for (const OrientedPoint& op : sampleProfileSurface(prof, 0.01, 1, true)) {
        const Eigen::Vector3d p = T_world_end * op.p.cast<double>();
        const Eigen::Vector3d n = T_world_end.linear() * op.n.cast<double>();
        if (op.p.z() < e.region_z_min || op.p.z() > e.region_z_max || p.z() < 0.01) continue;
        if (n.dot(T_world_color.translation() - p) <= 0) continue;  // back-facing
        Eigen::Vector2d uv;
        ASSERT_TRUE(color.project(T_world_color.inverse() * p, &uv));
        ++total;
        inside += uv.x() >= r.x_min - 1 && uv.x() <= r.x_max + 1 && uv.y() >= r.y_min - 1 &&
                  uv.y() <= r.y_max + 1;
      }
      ASSERT_GT(total, 20);
      EXPECT_EQ(inside, total) << sim.cameraName(c) << " " << labelName(e.label);
      // About the projected size: tool joint ~168 mm at 5.6-7.3 m -> 12-16 px wide.
      EXPECT_GT(r.x_max - r.x_min, 8);
      EXPECT_LT(r.x_max - r.x_min, 60);
      ++checked;
    }
  }
  EXPECT_GE(checked, 10);  // both ends in (nearly) every camera
}

TEST(SimDetector, ErrorRatesHoldOverManyFrames) {
  const SceneConfig scene = loadSceneConfig(scenePath("thesis_vertical"));
  SimulatorOptions opt;
  opt.profile = "ideal";
  opt.seed = 21;
  RigSimulator sim(loadRigCalibration(kRig), scene, opt);
  const SceneSnapshot snap = sim.scene().snapshot(0.0);
  const SimulatedDetector& det = sim.detector();
  const DetectorErrorModel& m = det.model();
  long regions_total = 0, primary = 0, swapped = 0, dups = 0, fps = 0, frames = 0;
  double jitter2 = 0;
  long jitter_n = 0;
  for (size_t c = 0; c < sim.numCameras(); ++c) {
    const PinholeCamera color = sim.sensor(c).color;
    const Eigen::Isometry3d T = sim.trueT_world_link(c);
    const auto regions = det.visibleRegions(sim.scene(), snap, color, T);
    for (uint64_t k = 0; k < 500; ++k, ++frames) {
      const auto boxes = det.detect(sim.scene(), snap, color, T, opt.seed, c, k);
      regions_total += regions.size();
      for (const DetectionBox& b : boxes) {
        const VisibleRegion* match = nullptr;
        for (const VisibleRegion& r : regions)
          if (b.x_max > r.x_min - 15 && b.x_min < r.x_max + 15 && b.y_max > r.y_min - 15 &&
              b.y_min < r.y_max + 15)
            match = &r;
        if (!match) {
          ++fps;
          continue;
        }
        if (b.confidence >= 0.6f) {
          ++primary;
          if (b.label != sim.scene().ends[match->end].label) ++swapped;
          jitter2 += std::pow(b.x_min - match->x_min, 2) + std::pow(b.y_max - match->y_max, 2);
          jitter_n += 2;
        } else {
          ++dups;
        }
      }
    }
  }
  const double miss = 1.0 - static_cast<double>(primary) / regions_total;
  const double swap = static_cast<double>(swapped) / primary;
  const double dup = static_cast<double>(dups) / primary;
  const double fp = static_cast<double>(fps) / frames;
  const double jitter = std::sqrt(jitter2 / jitter_n);
  std::printf(
      "[ detector ] %ld regions: miss %.3f swap %.3f dup %.3f fp/frame %.3f jitter %.2f px\n",
      regions_total, miss, swap, dup, fp, jitter);
  EXPECT_NEAR(miss, m.miss_probability, 0.025) << "seed " << opt.seed;
  EXPECT_NEAR(swap, m.swap_probability, 0.01) << "seed " << opt.seed;
  EXPECT_NEAR(dup, m.duplicate_probability, 0.015) << "seed " << opt.seed;
  EXPECT_NEAR(fp, m.false_positive_probability, 0.01) << "seed " << opt.seed;
  EXPECT_NEAR(jitter, m.edge_jitter_px, 0.4) << "seed " << opt.seed;
}

TEST(SimScenario, AllScenesLoadAndGroundTruthIsCanonical) {
  const RigCalibration rig = loadRigCalibration(kRig);
  EXPECT_EQ(rig.cameras.size(), 6u);
  for (const char* name : {"thesis_vertical", "thesis_angled", "catwalk_horizontal", "stabbing",
                           "cluttered", "dark_steel", "moving", "random_poses", "sodium_rust",
                           "sodium_rust_poses", "sodium_rust_floor"}) {
    const SceneConfig scene = loadSceneConfig(scenePath(name));
    SimulatorOptions opt;
    RigSimulator sim(rig, scene, opt);
    const auto truth = sim.groundTruth(1.0);
    ASSERT_FALSE(truth.empty()) << name;
    for (const auto& t : truth) {
      EXPECT_TRUE(t.T_world_end.isApprox(canonicalize(t.T_world_end), 1e-9)) << name;
      EXPECT_TRUE(sim.workZone().contains(t.T_world_end.translation()))
          << name << " " << labelName(t.label) << " at " << t.T_world_end.translation().transpose();
    }
    // Every scene renders.
    const RigSimulator::Frame f = sim.render(0, 1.0, 30);
    EXPECT_EQ(f.sensor_frame.depth.width, 512u) << name;
  }
  // Only the two scored ends of cluttered (the distractor pipe is not ground truth).
  RigSimulator cl(rig, loadSceneConfig(scenePath("cluttered")), SimulatorOptions());
  EXPECT_EQ(cl.groundTruth(0.0).size(), 2u);
  EXPECT_EQ(cl.scene().ends.size(), 4u);
  // Thesis tables.
  const SceneConfig v = loadSceneConfig(scenePath("thesis_vertical"));
  SimulatorOptions opt;
  RigSimulator sv(rig, v, opt);
  const auto tv = sv.groundTruth(0.0);
  ASSERT_EQ(tv.size(), 2u);
  EXPECT_TRUE(tv[0].T_world_end.translation().isApprox(Eigen::Vector3d(4.694, 5.3, 0.23)));
  EXPECT_TRUE(tv[1].T_world_end.translation().isApprox(Eigen::Vector3d(4.694, 6.8, 0.327)));
  EXPECT_NEAR(tv[0].T_world_end.linear().col(2).z(), 1.0, 1e-12);
  RigSimulator sa(rig, loadSceneConfig(scenePath("thesis_angled")), opt);
  const Eigen::Vector3d z = sa.groundTruth(0.0)[0].T_world_end.linear().col(2);
  EXPECT_NEAR(std::atan2(z.x(), z.z()) * 180 / M_PI, -30.6, 1e-9);
}

TEST(SimScenario, RandomPosesCoverTheSpec) {
  RigSimulator sim(loadRigCalibration(kRig), loadSceneConfig(scenePath("random_poses")),
                   SimulatorOptions());
  int horizontal = 0, hanging = 0, n = 0;
  for (int i = 0; i < 60; ++i) {
    for (const auto& t : sim.groundTruth(2.0 * i + 1.0)) {
      const Eigen::Vector3d p = t.T_world_end.translation(), z = t.T_world_end.linear().col(2);
      EXPECT_LE(std::abs(p.x() - 4.694), 1.0 + 1e-9);
      EXPECT_LE(std::abs(p.y() - 6.05), 1.0 + 1e-9);
      horizontal += std::abs(z.z()) < std::cos(75 * M_PI / 180);
      hanging += t.label == EndLabel::kPinEnd && z.z() < -0.9;
      ++n;
    }
  }
  EXPECT_EQ(n, 120);
  EXPECT_GT(horizontal, 10);
  EXPECT_GT(hanging, 8);
}

// sodium_rust_poses.yaml: standing_fraction 0.5 for both joints (the pin's hanging drawn first),
// standing_height [0.15, 0.7] m. A standing end is upright within 5 deg with its origin 0.15 m
// or more above the floor; below 0.5 m (under either end's resting height, 0.54 and 0.62 m) only
// a standing pose, sunk in the floor, can be.
TEST(SimScenario, StandingPosesStandInTheFloor) {
  RigSimulator sim(loadRigCalibration(kRig), loadSceneConfig(scenePath("sodium_rust_poses")),
                   SimulatorOptions());
  int sunk = 0, upright = 0, n = 0;
  for (int i = 0; i < 30; ++i) {
    for (const auto& t : sim.groundTruth(4.0 * i + 2.0)) {
      const double zz = t.T_world_end.linear().col(2).z(), h = t.T_world_end.translation().z();
      ++n;
      if (zz < std::cos(5.0 * M_PI / 180) - 1e-9) continue;
      ++upright;
      EXPECT_GE(h, 0.15 - 1e-9) << "pose " << i << " label " << static_cast<int>(t.label);
      sunk += h < 0.5;
    }
  }
  EXPECT_EQ(n, 60);
  // Expected about 25 standing poses (15 box, 10.5 pin), 64 % of them under 0.5 m: 16.
  EXPECT_GE(sunk, 8) << upright << " upright";
  EXPECT_LE(sunk, 26) << upright << " upright";
}

TEST(SimScenario, BadFilesNameFileKeyAndExpectation) {
  auto message = [](const std::string& text) {
    try {
      parseSceneConfig(text, "bad.yaml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string head = "name: x\nwork_zone: {min: [0, 0, 0], max: [1, 1, 1]}\n";
  const std::string pipe =
      "pipes: [{name: p, type: tool_joint, end: box_end, pose: {translation: [0, 0, 0]}}]\n";
  EXPECT_NE(message(pipe).find("bad.yaml: missing key \"name\""), std::string::npos);
  EXPECT_NE(message(head + "pipes: [{name: p, type: tool_joint, end: box_end, material: "
                           "unobtainium, pose: {translation: [0, 0, 0]}}]\n")
                .find("unknown material \"unobtainium\""),
            std::string::npos);
  EXPECT_NE(message(head + "pipes: [{name: p, type: tool_joint, end: box_end, pose: "
                           "{translation: [0, 0]}}]\n")
                .find("translation: expected a sequence of 3 numbers"),
            std::string::npos);
  EXPECT_NE(message(head + "pipes: [{name: p, type: tool_joint, end: middle, pose: "
                           "{translation: [0, 0, 0]}}]\n")
                .find("pipes[0].end"),
            std::string::npos);
  EXPECT_NE(message(head +
                    "objects: [{type: cylinder, radius: abc, height: 1, material: "
                    "concrete, pose: {translation: [0, 0, 0]}}]\n" +
                    pipe)
                .find("objects[0]: radius: expected a number"),
            std::string::npos);
  EXPECT_NE(message(head + pipe + "colour: red\n").find("unknown top-level key \"colour\""),
            std::string::npos);
  // A map as a key (found by test/fuzz/fuzz_scene_yaml): yaml-cpp's bad conversion escaped.
  EXPECT_NE(message(head + pipe + "{a: 1}: 2\n").find("bad.yaml: "), std::string::npos);
  EXPECT_NE(message(head + "pipes: [{name: p, type: tool_joint, end: box_end, pose: {translation: "
                           "[0, 0, 0]}, motion: {[v]: 1}}]\n")
                .find("bad.yaml: "),
            std::string::npos);
  // A target of 1e300 squares (found by fuzz_scene_yaml): converted to int, undefined behaviour.
  EXPECT_NE(message(head +
                    "calibration_target: {type: charuco, squares: [5, 1e300], square_length: "
                    "0.24, hold_s: 2, placements: [{translation: [0, 0, 1]}]}\n")
                .find("squares: expected two whole numbers, at most 1000"),
            std::string::npos);
  // The light: ambient is a fraction, the tint three gains in [0, 4].
  EXPECT_NE(message(head + pipe + "light: {direction: [0, 0, -1], ambient: 1.5}\n")
                .find("bad.yaml: light: ambient: expected a fraction in [0, 1]"),
            std::string::npos);
  EXPECT_NE(message(head + pipe + "light: {direction: [0, 0, -1], tint: [1, -0.1, 1]}\n")
                .find("bad.yaml: light: tint: expected three gains [b, g, r] in [0, 4]"),
            std::string::npos);
  EXPECT_NE(message(head + pipe + "light: {direction: [0, 0, -1], tint: [1, 1]}\n")
                .find("tint: expected a sequence of 3 numbers"),
            std::string::npos);
  // random_poses' standing share and heights, named with their place.
  const std::string poses = "pipes: [{name: p, type: tool_joint, end: box_end, pose: {translation: "
                            "[0, 0, 0]}, motion: {random_poses: {centre: [0, 0], ";
  EXPECT_NE(message(head + poses + "standing_fraction: 1.5}}}]\n")
                .find("pipes[0].motion.random_poses: standing_fraction: expected 0..1"),
            std::string::npos)
      << message(head + poses + "standing_fraction: 1.5}}}]\n");
  EXPECT_NE(message(head + poses + "standing_fraction: 0.5, standing_height: [0.7, 0.15]}}}]\n")
                .find("standing_height: expected [min, max] with 0 < min <= max < 100 [m]"),
            std::string::npos);
  EXPECT_THROW(sensorProfile("kinect_v3"), InputError);
}

TEST(SimRender, LightTintScalesEachColourChannel) {
  // The same scene under white light and under a tint: each channel of the noise-free colour
  // image scales by its gain (the ideal profile: no colour noise), the depth is unchanged.
  std::ifstream in(scenePath("thesis_vertical"));
  const std::string base((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const SceneConfig white = parseSceneConfig(base, "white");
  const SceneConfig tinted = parseSceneConfig(
      base + "light: {direction: [0.3, 0.2, -1], ambient: 0.35, tint: [0.5, 1.0, 0.25]}\n",
      "tinted");
  const RigCalibration rig = loadRigCalibration(kRig);
  SimulatorOptions opt;
  opt.profile = "ideal";
  opt.color = true;
  RigSimulator a(rig, white, opt), b(rig, tinted, opt);
  const RigSimulator::Frame fa = a.render(0, 0.0, 0), fb = b.render(0, 0.0, 0);
  ASSERT_EQ(fa.bgr.size(), fb.bgr.size());
  EXPECT_EQ(bytesOf(fa.sensor_frame.depth), bytesOf(fb.sensor_frame.depth));
  const double gain[3] = {0.5, 1.0, 0.25};
  double sum_a[3] = {0, 0, 0}, sum_b[3] = {0, 0, 0};
  for (size_t i = 0; i < fa.bgr.size(); ++i) {
    sum_a[i % 3] += fa.bgr[i];
    sum_b[i % 3] += fb.bgr[i];
  }
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(sum_b[c] / sum_a[c], gain[c], 0.02) << "channel " << c;  // 8-bit truncation
}

TEST(SimRender, OneSensorEffectSwitchesOffByName) {
  SensorEffects fx = sensorProfile("kinect_v2_calibrated");
  ASSERT_TRUE(fx.lateral_noise && fx.axial_noise && fx.depth_offset);
  switchOffEffect(&fx, "lateral_noise");
  EXPECT_FALSE(fx.lateral_noise);
  EXPECT_TRUE(fx.axial_noise && fx.depth_offset && fx.flying_pixels);
  switchOffEffect(&fx, "depth_offset");
  EXPECT_FALSE(fx.depth_offset);
  try {
    switchOffEffect(&fx, "lateral");
    FAIL() << "an unknown effect must be refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("\"lateral\" (expected one of axial_noise, "
                                         "lateral_noise"),
              std::string::npos)
        << e.what();
  }
}

/// A flat w x h view at depth z (head-on, reflectivity 0.6) with an invalid (z = 0) first row.
struct FlatView {
  std::vector<float> z, cos_incidence, reflectivity, g2;
  FlatView(int w, int h, float depth)
      : z(static_cast<size_t>(w) * h, depth),
        cos_incidence(z.size(), 1.0f),
        reflectivity(z.size(), 0.6f),
        g2(z.size(), 0.0f) {
    std::fill(z.begin(), z.begin() + w, 0.0f);
  }
  DepthSceneView view(int w, int h) const {
    DepthSceneView v;
    v.width = w;
    v.height = h;
    v.z = z.data();
    v.cos_incidence = cos_incidence.data();
    v.reflectivity = reflectivity.data();
    v.g2 = g2.data();
    return v;
  }
};

// A two-surface scene: the left half a bright board 1 m away, the right half a dark wall 1.2 m
// away, head-on; only the edge effects on.
TEST(SimDepthEffects, EdgePixelsAreInvalidOrMixedTowardsTheBrighterReturn) {
  const int W = 40, H = 30;
  FlatView scene(W, H, 1.0f);
  std::vector<float>& z = scene.z;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      z[v * W + u] = u < W / 2 ? 1.0f : 1.2f;
      scene.reflectivity[v * W + u] = u < W / 2 ? 0.8f : 0.1f;
    }
  const DepthSceneView in = scene.view(W, H);
  SensorEffects fx = sensorProfile("ideal");
  fx.flying_pixels = true;
  setEffectParameter(&fx, "edge_invalid_probability", 0.5);
  setEffectParameter(&fx, "flying_probability", 0.5);
  setEffectParameter(&fx, "flying_weight_min=0.1");
  setEffectParameter(&fx, "flying_weight_max=0.5");
  setEffectParameter(&fx, "flying_amplitude_weighted=1");
  DepthImage out;
  applyDepthEffects(fx, in, 0.0, 1.0, 11, 12, &out);
  int invalid = 0, mixed = 0, off_edge = 0;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const float d = out.depthAt(u, v);
      const bool edge = u == W / 2 - 1 || u == W / 2;
      if (!(d == d)) {
        ++invalid;
        off_edge += !edge;
      } else if (std::abs(d - z[v * W + u]) > 1e-6f) {
        ++mixed;
        off_edge += !edge;
        // The depth of a mixed pixel is the amplitude-weighted mean: nearer the bright board.
        EXPECT_LT(d, 1.1f) << "pixel " << u << "," << v;
        EXPECT_GT(d, 1.0f) << "pixel " << u << "," << v;
      }
    }
  std::printf("[ edges    ] %d of %d edge pixels invalid, %d mixed\n", invalid, 2 * H, mixed);
  EXPECT_EQ(off_edge, 0);
  EXPECT_EQ(invalid + mixed, 2 * H);  // the two probabilities sum to 1: every edge pixel
  EXPECT_GT(invalid, H / 2);          // about half of 2 H, seeds 11 and 12
  EXPECT_LT(invalid, 3 * H / 2);
}

TEST(SimDepthEffects, IdealProfileWritesTheInputDepthPlusOffset) {
  const int w = 7, h = 5;
  FlatView scene(w, h, 1.25f);
  scene.z[2 * w + 3] = 2.5f;
  const SensorEffects ideal = sensorProfile("ideal");
  DepthImage out;
  applyDepthEffects(ideal, scene.view(w, h), 0.004, 1.0, 1, 2, &out);
  ASSERT_EQ(out.encoding, DepthEncoding::kF32Metres);
  ASSERT_EQ(out.width, static_cast<uint32_t>(w));
  ASSERT_EQ(out.height, static_cast<uint32_t>(h));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const float z = out.depthAt(u, v);
      if (v == 0) {
        EXPECT_TRUE(z != z) << "no return must stay invalid at " << u << "," << v;
        continue;
      }
      EXPECT_EQ(z, scene.z[v * w + u] + 0.004f) << u << "," << v;
    }
  // With quantisation: millimetres, rounded.
  SensorEffects quantised = ideal;
  quantised.quantisation = true;
  applyDepthEffects(quantised, scene.view(w, h), 0.0, 1.0, 1, 2, &out);
  ASSERT_EQ(out.encoding, DepthEncoding::kU16Millimetres);
  EXPECT_FLOAT_EQ(out.depthAt(3, 2), 2.5f);
  EXPECT_FLOAT_EQ(out.depthAt(1, 1), 1.25f);
  EXPECT_TRUE(out.depthAt(1, 0) != out.depthAt(1, 0));
}

TEST(SimDepthEffects, TheAmplitudeImageIsTheModelsAmplitudeAndLeavesTheDepthAlone) {
  const int n = 40;
  FlatView scene(n, n + 1, 2.0f);  // rows 1..n at 2 m
  for (size_t i = 0; i < scene.reflectivity.size(); ++i) scene.reflectivity[i] = 0.5f;
  for (const char* profile : {"ideal", "kinect_v2_calibrated"}) {
    const SensorEffects fx = sensorProfile(profile);
    DepthImage plain, depth;
    AmplitudeImage amp;
    applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 7, 8, &plain);
    applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 7, 8, &depth, &amp);
    EXPECT_EQ(bytesOf(plain), bytesOf(depth)) << profile << ": no extra random draw";
    ASSERT_EQ(amp.width, static_cast<uint32_t>(n));
    ASSERT_EQ(amp.height, static_cast<uint32_t>(n + 1));
    EXPECT_EQ(amp.at(5, 0), 0.0f) << profile << ": no return, no amplitude";
    // a = reflectivity cos / z^2 (head-on) in digital numbers, from the pixel's own return.
    const float dn = 0.5f / 4.0f * static_cast<float>(kinect_v2::kDnPerAmplitude);
    EXPECT_NEAR(amp.at(7, 9), dn, 0.5f + 0.02f * dn) << profile;
  }
}

TEST(SimDepthEffects, AxialNoiseOfAFlatPatchMatchesTheModel) {
  const int n = 200;
  FlatView scene(n, n + 1, 1.0f);  // rows 1..n: the 200 x 200 patch
  SensorEffects fx = sensorProfile("ideal");
  fx.axial_noise = true;
  DepthImage out;
  applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 7, 8, &out);
  double sum = 0, sum2 = 0;
  int count = 0;
  for (int v = 1; v <= n; ++v)
    for (int u = 0; u < n; ++u) {
      const double z = out.depthAt(u, v);
      ASSERT_TRUE(z == z);
      sum += z;
      sum2 += z * z;
      ++count;
    }
  const double mean = sum / count;
  const double sigma = std::sqrt(sum2 / count - mean * mean);
  EXPECT_NEAR(mean, 1.0, 1e-4);
  EXPECT_NEAR(sigma / axialNoiseSigma(1.0, 0.0), 1.0, 0.10) << sigma;
  // Reproducible from the seeds; another noise seed, another realisation.
  DepthImage again, other;
  applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 7, 8, &again);
  applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 9, 8, &other);
  EXPECT_EQ(bytesOf(out), bytesOf(again));
  EXPECT_NE(bytesOf(out), bytesOf(other));
}

/// Mean, standard deviation and horizontal-neighbour correlation of rows 1..n of a
/// rendered n x (n + 1) flat view, and its count of invalid pixels.
struct PatchStats {
  double mean = 0, sigma = 0, corr = 0;
  int invalid = 0;
};
PatchStats patchStats(const DepthImage& img, int n) {
  PatchStats st;
  double sum = 0, sum2 = 0;
  int count = 0;
  for (int v = 1; v <= n; ++v)
    for (int u = 0; u < n; ++u) {
      const double z = img.depthAt(u, v);
      if (!(z > 0)) {
        ++st.invalid;
        continue;
      }
      sum += z;
      sum2 += z * z;
      ++count;
    }
  if (count == 0) return st;
  st.mean = sum / count;
  st.sigma = std::sqrt(std::max(0.0, sum2 / count - st.mean * st.mean));
  double sab = 0, saa = 0;
  for (int v = 1; v <= n; ++v)
    for (int u = 0; u + 1 < n; ++u) {
      const double a = img.depthAt(u, v) - st.mean, b = img.depthAt(u + 1, v) - st.mean;
      sab += a * b;
      saa += a * a;
    }
  st.corr = sab / saa;
  return st;
}

TEST(SimDepthEffects, AmplitudeNoiseFollowsTheFittedLaw) {
  const int n = 200;
  FlatView scene(n, n + 1, 1.0f);
  std::fill(scene.reflectivity.begin(), scene.reflectivity.end(), 0.02f);  // a = 0.02 / m^2
  SensorEffects fx = sensorProfile("ideal");
  fx.axial_noise = fx.amplitude_noise = true;
  DepthImage out;
  applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 3, 4, &out);
  const double weak = fx.amplitude_noise_coeff / 0.02;
  const double expected = std::sqrt(std::pow(fx.amplitude_noise_floor, 2) + weak * weak);
  EXPECT_GT(expected, 2.0 * axialNoiseSigma(1.0, 0.0));  // the amplitude term is the larger
  EXPECT_NEAR(patchStats(out, n).sigma / expected, 1.0, 0.1);
  EXPECT_NEAR(axialSigma(fx, 1.0f, 0.0f, 0.02f), expected, 1e-6);
  // A bright surface keeps the range law's sigma or the floor, whichever is larger.
  EXPECT_NEAR(axialSigma(fx, 1.0f, 0.0f, 10.0f),
              std::max(axialNoiseSigma(1.0, 0.0), fx.amplitude_noise_floor), 1e-5);
}

TEST(SimDepthEffects, CorrelatedNoiseHasTheConfiguredNeighbourCorrelation) {
  const int n = 200;
  FlatView scene(n, n + 1, 1.0f);
  SensorEffects fx = sensorProfile("ideal");
  fx.axial_noise = fx.correlated_noise = true;
  for (double rho : {0.3, 0.62}) {
    fx.noise_correlation = rho;
    DepthImage out;
    applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 5, 6, &out);
    const PatchStats st = patchStats(out, n);
    EXPECT_NEAR(st.corr, rho, 0.04) << "rho " << rho;
    EXPECT_NEAR(st.sigma / axialNoiseSigma(1.0, 0.0), 1.0, 0.1) << "rho " << rho;
  }
}

TEST(SimDepthEffects, BiasSaturationAndDepthScale) {
  const int n = 50;
  FlatView scene(n, n + 1, 2.0f);
  std::fill(scene.reflectivity.begin(), scene.reflectivity.end(), 0.1f);  // a = 0.025 / m^2
  SensorEffects fx = sensorProfile("ideal");
  fx.brightness_bias = true;
  fx.brightness_bias_reference = 0.0;
  DepthImage out;
  applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 1, 2, &out);
  EXPECT_NEAR(patchStats(out, n).mean - 2.0,
              fx.brightness_bias_coeff * std::pow(0.025, -fx.brightness_bias_power), 1e-5);
  // Below the lowest fitted amplitude the bias is held, not extrapolated.
  const float half_min = 0.5f * static_cast<float>(fx.brightness_bias_min_amplitude);
  EXPECT_FLOAT_EQ(brightnessBias(fx, 0.001f), brightnessBias(fx, half_min));
  // Calibrated at the reference amplitude: no bias there.
  fx.brightness_bias_reference = 0.025;
  EXPECT_NEAR(brightnessBias(fx, 0.025f), 0.0, 1e-7);
  // Saturation: above the ramp every pixel is invalid, below it none.
  fx = sensorProfile("ideal");
  fx.saturation = true;
  std::fill(scene.reflectivity.begin(), scene.reflectivity.end(), 1.0f);
  FlatView near(n, n + 1, 0.5f);  // a = 4 / m^2
  applyDepthEffects(fx, near.view(n, n + 1), 0.0, 1.0, 1, 2, &out);
  EXPECT_EQ(patchStats(out, n).invalid, n * n);
  applyDepthEffects(fx, scene.view(n, n + 1), 0.0, 1.0, 1, 2, &out);  // a = 0.25 / m^2
  EXPECT_EQ(patchStats(out, n).invalid, 0);
  // Depth scale and offset: z * scale + offset.
  applyDepthEffects(sensorProfile("ideal"), scene.view(n, n + 1), 0.01, 0.98, 1, 2, &out);
  EXPECT_NEAR(out.depthAt(3, 3), 2.0 * 0.98 + 0.01, 1e-6);
}

TEST(SimRender, SpeedReport) {
  const RigCalibration rig = loadRigCalibration(kRig);
  for (const char* name : {"thesis_vertical", "moving", "cluttered"}) {
    SimulatorOptions opt;
    opt.profile = "kinect_v2_field";
    RigSimulator sim(rig, loadSceneConfig(scenePath(name)), opt);
    auto t0 = std::chrono::steady_clock::now();
    for (size_t c = 0; c < sim.numCameras(); ++c) sim.render(c, 0.0, 0);  // background caches
    auto t1 = std::chrono::steady_clock::now();
    const auto caps = sim.captures(0.0, 1.0);
    for (const Capture& cap : caps) sim.render(cap.camera, cap.t, cap.frame_index);
    auto t2 = std::chrono::steady_clock::now();
    SimulatorOptions no_det = opt;
    no_det.simulated_detection = false;
    RigSimulator sim2(rig, loadSceneConfig(scenePath(name)), no_det);
    for (size_t c = 0; c < sim2.numCameras(); ++c) sim2.render(c, 0.0, 0);
    auto t3 = std::chrono::steady_clock::now();
    for (const Capture& cap : caps) sim2.render(cap.camera, cap.t, cap.frame_index);
    const double per_nodet =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t3).count() /
        caps.size();
    std::printf("[ speed    ] %s: %.2f ms per camera frame without detection\n", name, per_nodet);
    const double first = std::chrono::duration<double, std::milli>(t1 - t0).count();
    const double per = std::chrono::duration<double, std::milli>(t2 - t1).count() / caps.size();
    std::printf(
        "[ speed    ] %s: first frames (background cache) %.0f ms for %zu cameras; "
        "%.2f ms per camera frame with detection (%zu frames), %.1f ms per 6-camera set\n",
        name, first, sim.numCameras(), per, caps.size(), per * 6);
  }
}

TEST(SimScenario, SensorFileMatchesBuiltIn) {
  const SensorIntrinsics f = loadSensorIntrinsics(kSource + "/config/sensors/kinect_v2.yaml");
  const SensorIntrinsics b = SensorIntrinsics::kinectV2();
  EXPECT_EQ(f.name, b.name);
  EXPECT_EQ(f.depth.imageWidth(), b.depth.imageWidth());
  EXPECT_EQ(f.color.imageHeight(), b.color.imageHeight());
  EXPECT_DOUBLE_EQ(f.depth.fx(), b.depth.fx());
  EXPECT_DOUBLE_EQ(f.color.cx(), b.color.cx());
  EXPECT_TRUE(f.T_color_depth.isApprox(b.T_color_depth));
  EXPECT_DOUBLE_EQ(f.frame_rate_hz, 30.0);
  EXPECT_THROW(loadSensorIntrinsics(kSource + "/config/sensors/no_such_sensor.yaml"), InputError);
}
