// The calibration target: its frame, texture, validation and detection on synthetic pinhole
// images of a known pose (area-sampled, 16 samples per pixel, so that the edges are as a real
// sensor integrates them).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/errors.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::calibration;

namespace {

TargetGeometry charuco() { return TargetGeometry{}; }  // the rig's 5 x 5 board of 0.24 m

TargetGeometry chessboard() {
  TargetGeometry t;
  t.type = TargetGeometry::Type::kChessboard;
  t.squares_x = 6;
  t.squares_y = 8;
  t.square_length = 0.03;
  return t;
}

struct View {
  Eigen::Matrix3d K;
  Eigen::Isometry3d T_cam_target;
  int width = 960, height = 720;
};

/// A camera `distance` metres in front of the printed face (target +z), looking at its centre,
/// image x along target x, then the target turned by `tilt_x_deg` / `tilt_y_deg` about its axes.
View makeView(double f, double distance, double tilt_x_deg, double tilt_y_deg, double roll_deg) {
  View v;
  v.K << f, 0, (v.width - 1) / 2.0, 0, f, (v.height - 1) / 2.0, 0, 0, 1;
  Eigen::Isometry3d T_cam_front = Eigen::Isometry3d::Identity();  // camera x = target x,
  T_cam_front.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;            // camera y = -target y
  T_cam_front.translation() = Eigen::Vector3d(0.0, 0.0, distance);
  Eigen::Isometry3d tilt = Eigen::Isometry3d::Identity();
  tilt.linear() = (Eigen::AngleAxisd(roll_deg * M_PI / 180, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(tilt_x_deg * M_PI / 180, Eigen::Vector3d::UnitX()) *
                   Eigen::AngleAxisd(tilt_y_deg * M_PI / 180, Eigen::Vector3d::UnitY()))
                      .toRotationMatrix();
  v.T_cam_target = T_cam_front * tilt;
  return v;
}

/// Grey image of the target seen by `view`: white paper margin of half a square around the
/// squares, a grey wall (albedo 0.5) beyond; 4 x 4 samples per pixel averaged; Gaussian noise of
/// `noise_sigma` grey levels (seeded).
cv::Mat render(const TargetGeometry& t, const TargetTexture& tex, const View& view,
               double noise_sigma, unsigned seed) {
  // Homography pixel -> target plane point: H = K [r1 r2 t], inverted.
  Eigen::Matrix3d H;
  H.col(0) = view.T_cam_target.linear().col(0);
  H.col(1) = view.T_cam_target.linear().col(1);
  H.col(2) = view.T_cam_target.translation();
  const Eigen::Matrix3d Hinv = (view.K * H).inverse();
  const Eigen::Vector2d half = targetSize(t) / 2.0 + Eigen::Vector2d::Constant(t.square_length / 2);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_sigma);
  cv::Mat img(view.height, view.width, CV_8U);
  // 16 samples per pixel on distinct rows and columns (an n-rooks pattern): an axis-aligned edge
  // is resolved to 1/16 px, where a 4 x 4 grid would snap it to 1/4 px.
  constexpr int kS = 16;
  for (int v = 0; v < view.height; ++v)
    for (int u = 0; u < view.width; ++u) {
      double sum = 0;
      for (int k = 0; k < kS; ++k) {
        const double du = (k + 0.5) / kS - 0.5, dv = ((5 * k) % kS + 0.5) / kS - 0.5;
        const Eigen::Vector3d q = Hinv * Eigen::Vector3d(u + du, v + dv, 1.0);
        const double x = q.x() / q.z(), y = q.y() / q.z();
        double alb = tex.albedo(x, y);
        if (alb < 0) alb = (std::abs(x) < half.x() && std::abs(y) < half.y()) ? 1.0 : 0.5;
        sum += alb;
      }
      const double g = 20.0 + 210.0 * sum / kS + (noise_sigma > 0 ? noise(rng) : 0.0);
      img.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(g);
    }
  return img;
}

Eigen::Vector2d project(const View& view, const Eigen::Vector3d& p_target) {
  const Eigen::Vector3d p = view.K * (view.T_cam_target * p_target);
  return p.head<2>() / p.z();
}

/// Largest distance [px] between a detected corner and the projection of its targetCorners().
double maxError(const TargetGeometry& t, const View& view,
                const std::vector<CornerObservation>& found, bool reversed = false) {
  const std::vector<Eigen::Vector3d> corners = targetCorners(t);
  double worst = 0;
  for (const CornerObservation& c : found) {
    const int id = reversed ? static_cast<int>(corners.size()) - 1 - c.id : c.id;
    worst = std::max(worst, (c.uv - project(view, corners.at(id))).norm());
  }
  return worst;
}

}  // namespace

TEST(CalibrationTarget, CharucoCornersInOurFrame) {
  const std::vector<Eigen::Vector3d> c = targetCorners(charuco());
  ASSERT_EQ(c.size(), 16u);
  // Id 0 is the inner corner nearest the top-left of the print (target -x, +y), ids run along +x.
  EXPECT_TRUE(c[0].isApprox(Eigen::Vector3d(-0.36, 0.36, 0.0), 1e-6)) << c[0].transpose();
  EXPECT_TRUE(c[1].isApprox(Eigen::Vector3d(-0.12, 0.36, 0.0), 1e-6)) << c[1].transpose();
  EXPECT_TRUE(c[4].isApprox(Eigen::Vector3d(-0.36, 0.12, 0.0), 1e-6)) << c[4].transpose();
  EXPECT_TRUE(c[15].isApprox(Eigen::Vector3d(0.36, -0.36, 0.0), 1e-6)) << c[15].transpose();
  EXPECT_TRUE(targetSize(charuco()).isApprox(Eigen::Vector2d(1.2, 1.2)));
}

TEST(CalibrationTarget, TextureMatchesTheFrame) {
  const TargetTexture tex(charuco(), 60);
  EXPECT_EQ(tex.image().cols, 300);
  EXPECT_EQ(tex.image().rows, 300);
  // OpenCV draws the top-left square of the print black: target (-x, +y) corner.
  EXPECT_EQ(tex.albedo(-0.59, 0.59), 0.0);
  EXPECT_EQ(tex.albedo(-0.35, 0.59), 1.0);  // the white gap above the first marker
  EXPECT_EQ(tex.albedo(0.61, 0.0), -1.0);
  EXPECT_EQ(tex.albedo(0.0, -0.61), -1.0);
  const TargetTexture board(chessboard(), 20);
  EXPECT_EQ(board.albedo(-0.089, 0.119), 0.0);  // top-left square of the print: black
  EXPECT_EQ(board.albedo(-0.059, 0.119), 1.0);
}

TEST(CalibrationTarget, CharucoDetectedWithinTenthsOfAPixel) {
  const TargetGeometry t = charuco();
  const TargetTexture tex(t, 120);
  struct Case {
    double f, distance, tilt_x, tilt_y, roll, noise;
  };
  // Squares of about 60-100 px, as the HD cameras see the board at 3-5 m; views up to 50 deg.
  const Case cases[] = {{540, 2.0, 0, 0, 0, 0},    {540, 2.4, 35, 0, 10, 0},
                        {540, 2.2, -20, 40, -25, 0}, {540, 2.5, 0, 50, 90, 0},
                        {540, 2.0, 15, 15, 180, 2.0}};
  unsigned seed = 11;
  for (const Case& c : cases) {
    const View view = makeView(c.f, c.distance, c.tilt_x, c.tilt_y, c.roll);
    const cv::Mat img = render(t, tex, view, c.noise, seed++);
    const std::vector<CornerObservation> found = detectTarget(t, img);
    SCOPED_TRACE("seed " + std::to_string(seed - 1) + " tilt " + std::to_string(c.tilt_x) + "/" +
                 std::to_string(c.tilt_y) + " roll " + std::to_string(c.roll));
    EXPECT_EQ(found.size(), 16u);
    const double err = maxError(t, view, found);
    EXPECT_LT(err, 0.2);
    std::printf("charuco tilt %g/%g roll %g noise %g: %zu corners, max error %.3f px\n", c.tilt_x,
                c.tilt_y, c.roll, c.noise, found.size(), err);
  }
}

TEST(CalibrationTarget, ChessboardDetectedUpToAHalfTurn) {
  const TargetGeometry t = chessboard();
  const TargetTexture tex(t, 40);
  unsigned seed = 21;
  for (double tilt : {0.0, 30.0, 45.0}) {
    const View view = makeView(900, 0.35, tilt, tilt / 2, 5.0);
    const cv::Mat img = render(t, tex, view, 1.0, seed++);
    const std::vector<CornerObservation> found = detectTarget(t, img);
    SCOPED_TRACE("seed " + std::to_string(seed - 1) + " tilt " + std::to_string(tilt));
    ASSERT_EQ(found.size(), 35u);
    // OpenCV's order, or its reverse (the half-turn ambiguity the solver resolves).
    const double err = std::min(maxError(t, view, found), maxError(t, view, found, true));
    EXPECT_LT(err, 0.2);
    std::printf("chessboard tilt %g: max error %.3f px\n", tilt, err);
  }
}

TEST(CalibrationTarget, NothingFoundInABlankImage) {
  const cv::Mat blank(480, 640, CV_8U, cv::Scalar(128));
  EXPECT_TRUE(detectTarget(charuco(), blank).empty());
  EXPECT_TRUE(detectTarget(chessboard(), blank).empty());
  EXPECT_THROW(detectTarget(charuco(), cv::Mat(4, 4, CV_16U)), InputError);
}

namespace {
void expectInvalid(TargetGeometry t, const std::string& field) {
  try {
    validateTarget(t, "scene.yaml calibration_target");
    ADD_FAILURE() << "no error for " << field;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("scene.yaml calibration_target"), std::string::npos) << what;
    EXPECT_NE(what.find(field), std::string::npos) << what;
  }
}
}  // namespace

TEST(CalibrationTarget, ValidationNamesTheField) {
  EXPECT_NO_THROW(validateTarget(charuco(), "x"));
  EXPECT_NO_THROW(validateTarget(chessboard(), "x"));
  TargetGeometry t = charuco();
  t.squares_x = 1;
  expectInvalid(t, "squares_x = 1");
  t = charuco();
  t.squares_y = 0;
  expectInvalid(t, "squares_y = 0");
  t = chessboard();
  t.squares_x = 3;  // 2 inner corners: too few for findChessboardCorners
  expectInvalid(t, "squares_x = 3");
  t = charuco();
  t.square_length = -0.1;
  expectInvalid(t, "square_length = -0.1");
  t = charuco();
  t.marker_length = 0;
  expectInvalid(t, "marker_length = 0");
  t = charuco();
  t.marker_length = 0.24;
  expectInvalid(t, "marker_length = 0.24");
  t = charuco();
  t.dictionary = "DICT_9X9_7";
  expectInvalid(t, "dictionary = \"DICT_9X9_7\"");
  t = charuco();
  t.squares_x = 11;
  t.squares_y = 11;  // 60 markers: DICT_4X4_50 holds 50
  expectInvalid(t, "needs 60");
}
