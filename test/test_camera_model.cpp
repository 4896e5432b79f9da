// Camera model: analytic projection cases, roi crops, colour/depth registration, bad CameraInfo.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/errors.hpp"

using namespace drill_pipe_pose;

namespace {

// Kinect v2 SD depth and QHD colour intrinsics (iai_kinect2 factory values), as a CameraInfo would
// carry them.
CameraInfoData kinectDepthInfo() {
  CameraInfoData c;
  c.frame_id = "cam1_ir_optical_frame";
  c.width = 512;
  c.height = 424;
  c.distortion_model = "plumb_bob";
  c.D = {0, 0, 0, 0, 0};
  c.K = {365.4, 0, 260.9, 0, 365.4, 205.6, 0, 0, 1};
  c.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.P = {365.4, 0, 260.9, 0, 0, 365.4, 205.6, 0, 0, 0, 1, 0};
  return c;
}

CameraInfoData kinectColorInfo() {
  CameraInfoData c = kinectDepthInfo();
  c.frame_id = "cam1_rgb_optical_frame";
  c.width = 960;
  c.height = 540;
  c.K = {540.7, 0, 479.75, 0, 540.7, 269.75, 0, 0, 1};
  c.P = {540.7, 0, 479.75, 0, 0, 540.7, 269.75, 0, 0, 0, 1, 0};
  return c;
}

// Expects fromCameraInfo to throw an InputError whose message contains every `needle`.
void expectRejected(const CameraInfoData& info, std::initializer_list<const char*> needles) {
  try {
    PinholeCamera::fromCameraInfo(info, "cam7 depth_info");
    FAIL() << "accepted a bad CameraInfo; expected an error naming " << *needles.begin();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("cam7 depth_info"), std::string::npos) << msg;
    for (const char* n : needles) EXPECT_NE(msg.find(n), std::string::npos) << msg;
  }
}

}  // namespace

TEST(PinholeCamera, ReadsIntrinsicsFromP) {
  const auto cam = PinholeCamera::fromCameraInfo(kinectDepthInfo(), "test");
  EXPECT_DOUBLE_EQ(cam.fx(), 365.4);
  EXPECT_DOUBLE_EQ(cam.cy(), 205.6);
  EXPECT_EQ(cam.imageWidth(), 512u);
  EXPECT_EQ(cam.imageHeight(), 424u);
}

TEST(PinholeCamera, FallsBackToKWhenPUnsetAndUndistorted) {
  CameraInfoData info = kinectDepthInfo();
  info.P = {};
  const auto cam = PinholeCamera::fromCameraInfo(info, "test");
  EXPECT_DOUBLE_EQ(cam.fx(), 365.4);
}

TEST(PinholeCamera, ProjectBackProjectRoundTrip) {
  const unsigned seed = 42;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uu(-0.5, 511.4), vv(-0.5, 423.4), zz(0.5, 8.0);
  const auto cam = PinholeCamera::fromCameraInfo(kinectDepthInfo(), "test");
  for (int i = 0; i < 1000; ++i) {
    const double u = uu(rng), v = vv(rng), z = zz(rng);
    const Eigen::Vector3d p = cam.backProject(u, v, z);
    EXPECT_DOUBLE_EQ(p.z(), z);
    Eigen::Vector2d uv;
    ASSERT_TRUE(cam.project(p, &uv)) << "seed " << seed << " i " << i;
    EXPECT_NEAR(uv.x(), u, 1e-9) << "seed " << seed << " i " << i;
    EXPECT_NEAR(uv.y(), v, 1e-9) << "seed " << seed << " i " << i;
    EXPECT_TRUE(cam.contains(uv));
  }
}

TEST(PinholeCamera, AnalyticProjection) {
  const auto cam = PinholeCamera::fromCameraInfo(kinectDepthInfo(), "test");
  Eigen::Vector2d uv;
  ASSERT_TRUE(cam.project({0.5, -0.25, 5.0}, &uv));
  EXPECT_NEAR(uv.x(), 260.9 + 365.4 * 0.1, 1e-9);
  EXPECT_NEAR(uv.y(), 205.6 - 365.4 * 0.05, 1e-9);
  EXPECT_FALSE(cam.project({0.0, 0.0, -1.0}, &uv));
  EXPECT_FALSE(cam.project({0.0, 0.0, 0.0}, &uv));
}

TEST(PinholeCamera, RoiCropShiftsPixelsButNotRays) {
  CameraInfoData info = kinectDepthInfo();
  const auto full = PinholeCamera::fromCameraInfo(info, "test");
  info.roi = {100, 50, 64, 32};
  const auto crop = PinholeCamera::fromCameraInfo(info, "test");
  EXPECT_EQ(crop.imageWidth(), 64u);
  EXPECT_EQ(crop.imageHeight(), 32u);
  for (int v = 0; v < 32; ++v)
    for (int u = 0; u < 64; ++u) {
      const Eigen::Vector3d a = crop.backProject(u, v, 3.0);
      const Eigen::Vector3d b = full.backProject(u + 100, v + 50, 3.0);
      ASSERT_NEAR((a - b).norm(), 0.0, 1e-12) << "u " << u << " v " << v;
    }
  Eigen::Vector2d uv;
  ASSERT_TRUE(crop.project(full.backProject(120.0, 60.0, 2.0), &uv));
  EXPECT_NEAR(uv.x(), 20.0, 1e-9);
  EXPECT_NEAR(uv.y(), 10.0, 1e-9);
  EXPECT_TRUE(crop.contains(uv));
  ASSERT_TRUE(crop.project(full.backProject(10.0, 10.0, 2.0), &uv));
  EXPECT_FALSE(crop.contains(uv));
}

TEST(DepthToColorRegistration, PointOnAxisLandsOnItsColourPixel) {
  const auto depth = PinholeCamera::fromCameraInfo(kinectDepthInfo(), "depth");
  const auto color = PinholeCamera::fromCameraInfo(kinectColorInfo(), "color");
  Eigen::Isometry3d T_color_depth = Eigen::Isometry3d::Identity();
  T_color_depth.translation() << 0.052, 0.0, 0.0;
  const DepthToColorRegistration reg(depth, color, T_color_depth);
  // The point on the depth camera's axis at 2 m is 52 mm right of the colour camera's axis.
  Eigen::Vector2d uv;
  ASSERT_TRUE(reg.registerPixel(260.9, 205.6, 2.0, &uv));
  EXPECT_NEAR(uv.x(), 479.75 + 540.7 * 0.052 / 2.0, 1e-9);
  EXPECT_NEAR(uv.y(), 269.75, 1e-9);
}

TEST(DepthToColorRegistration, PointSeenByBothCamerasLandsOnItsPixelInEach) {
  const unsigned seed = 7;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-1.5, 1.5), zz(1.0, 7.0), ang(-0.05, 0.05);
  const auto depth = PinholeCamera::fromCameraInfo(kinectDepthInfo(), "depth");
  const auto color = PinholeCamera::fromCameraInfo(kinectColorInfo(), "color");
  Eigen::Isometry3d T_color_depth = Eigen::Isometry3d::Identity();
  T_color_depth.linear() = (Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(-0.02, Eigen::Vector3d::UnitX()))
                               .toRotationMatrix();
  T_color_depth.translation() << -0.0515, 0.001, -0.001;
  const DepthToColorRegistration reg(depth, color, T_color_depth);
  const Eigen::Matrix3d Kc =
      Eigen::Map<const Eigen::Matrix3d>(kinectColorInfo().K.data()).transpose();
  int checked = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d p_color(xy(rng), xy(rng), zz(rng));
    const Eigen::Vector3d p_depth = T_color_depth.inverse() * p_color;
    Eigen::Vector2d uv_d, uv_c;
    if (!depth.project(p_depth, &uv_d) || !depth.contains(uv_d)) continue;
    ASSERT_TRUE(reg.registerPixel(uv_d.x(), uv_d.y(), p_depth.z(), &uv_c));
    const Eigen::Vector3d h = Kc * p_color;  // independent pinhole projection
    EXPECT_NEAR(uv_c.x(), h.x() / h.z(), 1e-6) << "seed " << seed << " i " << i;
    EXPECT_NEAR(uv_c.y(), h.y() / h.z(), 1e-6) << "seed " << seed << " i " << i;
    ++checked;
  }
  EXPECT_GT(checked, 200);
}

TEST(PinholeCameraBadInput, ZeroFocalLength) {
  CameraInfoData info = kinectDepthInfo();
  info.P[0] = 0.0;
  info.P[5] = 0.0;
  info.K[0] = 0.0;
  expectRejected(info, {"K[0] (fx)", "= 0"});
}

TEST(PinholeCameraBadInput, NanFocalLength) {
  CameraInfoData info = kinectDepthInfo();
  info.P[5] = std::nan("");
  expectRejected(info, {"P[5] (fy)", "nan"});
}

TEST(PinholeCameraBadInput, ZeroSize) {
  CameraInfoData info = kinectDepthInfo();
  info.width = 0;
  expectRejected(info, {"width = 0"});
}

TEST(PinholeCameraBadInput, DistortedImageWithoutP) {
  CameraInfoData info = kinectDepthInfo();
  info.P = {};
  info.D = {0.1, 0, 0, 0, 0};
  expectRejected(info, {"D[0] = 0.1", "not rectified"});
}

TEST(PinholeCameraBadInput, StereoBaseline) {
  CameraInfoData info = kinectDepthInfo();
  info.P[3] = -40.0;
  expectRejected(info, {"P[3] = -40"});
}

TEST(PinholeCameraBadInput, Binning) {
  CameraInfoData info = kinectDepthInfo();
  info.binning_x = 2;
  expectRejected(info, {"binning_x = 2"});
}

TEST(PinholeCameraBadInput, RoiOutsideSensor) {
  CameraInfoData info = kinectDepthInfo();
  info.roi = {500, 0, 64, 32};
  expectRejected(info, {"roi.x_offset + roi.width = 564", "width = 512"});
  info.roi = {0, 400, 64, 32};
  expectRejected(info, {"roi.y_offset + roi.height = 432", "height = 424"});
  info.roi = {10, 10, 0, 0};
  expectRejected(info, {"roi.width = 0"});
}
