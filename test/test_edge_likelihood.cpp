// The edge likelihood (core/estimator/edge_likelihood) on synthetic views: a 5" NC50 box end
// standing 0.23 m above a floor, seen by four cameras 4.8 m up and 5.5-6.2 m away (the thesis
// lab's geometry), rendered exactly from the model itself; then its pixels beside depth steps
// dropped or mixed as a Kinect v2 reads them.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "drill_pipe_pose/core/estimator/edge_likelihood.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"

namespace drill_pipe_pose {
namespace {

constexpr int kW = 512, kH = 424;

/// A Kinect v2-like depth camera at `eye` looking at `target` (world z up).
CycleCamera cameraAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  CycleCamera cam;
  cam.name = "synthetic";
  cam.depth = PinholeCamera::fromIntrinsics(kW, kH, 365.0, 365.0, 256.0, 212.0);
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  cam.T_world_depth.linear() = R;
  cam.T_world_depth.translation() = eye;
  cam.image = DepthImage::allocate(kW, kH, DepthEncoding::kF32Metres);
  cam.crop = {{0, 0, kW, kH}};
  return cam;
}

/// The optical depth of every pixel: the model at T_world_end, else the floor (world z = 0).
std::vector<float> render(const CycleCamera& cam, const ProfileModel& model,
                          const Eigen::Isometry3d& T_world_end) {
  std::vector<float> z(static_cast<size_t>(kW) * kH, std::numeric_limits<float>::quiet_NaN());
  const Eigen::Isometry3d T_end_depth = T_world_end.inverse() * cam.T_world_depth;
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      const Eigen::Vector3d ray = cam.depth.backProject(u, v, 1.0);
      double s;
      Eigen::Vector2d zr, n;
      const Eigen::Vector3d d_end = T_end_depth.linear() * ray.normalized();
      float depth;
      if (model.rayHit(T_end_depth.translation(), d_end, 0.0, &s, &zr, &n)) {
        depth = static_cast<float>(s / ray.norm());
      } else {
        const Eigen::Vector3d d_world = cam.T_world_depth.linear() * ray;  // optical z = 1
        if (!(d_world.z() < -1e-6)) continue;
        depth = static_cast<float>(-cam.T_world_depth.translation().z() / d_world.z());
      }
      z[static_cast<size_t>(v) * kW + u] = depth;
    }
  return z;
}

/// Writes `z` into the camera's image; with `mix`, every pixel beside a jump of more than 5 cm
/// is dropped (half of them) or mixed: moved a share t (uniform 0-0.5, a mixed pixel stays near
/// the nearer, brighter return) toward the neighbour across the jump.
void writeImage(const std::vector<float>& z, bool mix, uint32_t seed, CycleCamera* cam) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  const auto at = [&](int u, int v) { return z[static_cast<size_t>(v) * kW + u]; };
  for (int v = 1; v < kH - 1; ++v)
    for (int u = 1; u < kW - 1; ++u) {
      float d = at(u, v);
      if (!(d == d)) continue;
      if (mix) {
        float across = d, jump = 0.05f;
        for (const auto& [du, dv] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
          const float n = at(u + du, v + dv);
          if (n == n && std::abs(n - d) > jump) jump = std::abs(n - d), across = n;
        }
        if (across != d) {
          if (u01(rng) < 0.5f) continue;  // dropped
          d += 0.5f * u01(rng) * (across - d);
        }
      }
      cam->image.setDepth(u, v, d);
    }
}

struct Scene {
  ProfileModel model{EndLabel::kBoxEnd, ToolJointDimensions()};
  Eigen::Isometry3d T_world_end = canonicalPose(Eigen::Vector3d(4.694, 5.3, 0.23),
                                                Eigen::Vector3d::UnitZ());
  std::vector<CycleCamera> cams;

  Scene(bool mix, uint32_t seed) {
    const Eigen::Vector3d target(4.694, 5.3, 0.2);
    for (int k = 0; k < 4; ++k) {
      const double a = k * M_PI / 2 + 0.3, r = 5.5 + 0.23 * k;
      cams.push_back(cameraAt(target + Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 4.6),
                              target));
      writeImage(render(cams.back(), model, T_world_end), mix, seed + k, &cams.back());
    }
  }

  /// The scan's best offset [m] along the axis from a start `start` [m] off the truth; with
  /// `changing_only`, on the pixels that the scan can change alone (keepChangingPixels).
  double bestOffset(double start, EdgeOutcomes* outcomes = nullptr,
                    bool changing_only = false) const {
    const EstimatorConfig::Edges edges;
    const EstimatorConfig::Noise noise;
    const Eigen::Vector3d z = T_world_end.linear().col(2);
    const Eigen::Vector3d o = T_world_end.translation() + start * z;
    auto regions = edgeRegions(model, 0.094, canonicalPose(o, z), cams, edges, edges.scan_range);
    const EdgeOutcomes out =
        estimateEdgeOutcomes(model, canonicalPose(o, z), cams, regions, edges, noise, 0.03);
    if (outcomes) *outcomes = out;
    if (changing_only)
      keepChangingPixels(model, canonicalPose(o, z), edges.scan_range, cams, noise, 0.03,
                         &regions);
    double best = std::numeric_limits<double>::infinity(), best_d = 0;
    for (double d = -edges.scan_range; d <= edges.scan_range + 1e-9; d += 0.001) {
      const double c =
          edgeNegLogLikelihood(model, canonicalPose(o + d * z, z), cams, regions, out, noise, 0.03);
      if (c < best) best = c, best_d = d;
    }
    return start + best_d;
  }
};

TEST(EdgeLikelihood, ExactViewsPlaceTheEndWhereItIs) {
  const Scene scene(false, 1);
  for (double start : {-0.009, 0.0, 0.012}) {
    SCOPED_TRACE("start " + std::to_string(start * 1e3) + " mm off");
    EXPECT_NEAR(scene.bestOffset(start), 0.0, 0.0015);
  }
}

TEST(EdgeLikelihood, DroppedAndMixedEdgePixelsStillPlaceTheEnd) {
  for (uint32_t seed : {11u, 12u}) {
    const Scene scene(true, seed);
    EdgeOutcomes out;
    const double d = scene.bestOffset(-0.009, &out);
    SCOPED_TRACE("seed " + std::to_string(seed));
    EXPECT_NEAR(d, 0.0, 0.003);
    // The pixels the scan cannot change add the same to every pose: the same best pose without.
    EXPECT_DOUBLE_EQ(scene.bestOffset(-0.009, nullptr, true), d);
    // The pixels say what they do: beside a step about half are missing, away from steps few
    // (those the 9 mm start puts on the model's side of a step).
    const double p_missing_step = std::exp(-out.nll[EdgeOutcomes::kStepFront][0]);
    EXPECT_GT(p_missing_step, 0.3);
    EXPECT_LT(p_missing_step, 0.7);
    EXPECT_LT(std::exp(-out.nll[EdgeOutcomes::kOn][0]), 0.15);
  }
}

TEST(EdgeLikelihood, ACameraThatDoesNotSeeTheEndIsLeftOut) {
  Scene scene(false, 1);
  scene.cams.push_back(cameraAt(Eigen::Vector3d(4.694, 5.3, 5.0), Eigen::Vector3d(4.694, 9.0, 5.0)));
  const EstimatorConfig::Edges edges;
  const auto regions =
      edgeRegions(scene.model, 0.094, scene.T_world_end, scene.cams, edges, edges.scan_range);
  ASSERT_EQ(regions.size(), scene.cams.size());
  EXPECT_EQ(regions.back().rect, (std::array<int, 4>{{0, 0, 0, 0}}));
  EXPECT_NEAR(scene.bestOffset(0.0), 0.0, 0.0015);
}

TEST(EdgeLikelihood, EachCameraSaysWhetherItsPixelsReadAsEdges) {
  // Four cameras whose edge pixels are dropped or mixed; the first one's view instead loses a
  // third of all its pixels alike (something dark in front of the end): its shares say so.
  Scene scene(true, 21);
  CycleCamera& cam = scene.cams[0];
  const std::vector<float> z = render(cam, scene.model, scene.T_world_end);
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
      cam.image.setDepth(u, v, u01(rng) < 0.33f ? std::numeric_limits<float>::quiet_NaN()
                                                : z[static_cast<size_t>(v) * kW + u]);
  EdgeOutcomes out;
  scene.bestOffset(0.0, &out);
  ASSERT_EQ(out.camera_pixels.size(), 4u);
  for (size_t c = 0; c < 4; ++c) {
    SCOPED_TRACE("seed 21, camera " + std::to_string(c));
    EXPECT_GT(out.camera_pixels[c], 50);
    const double step = out.camera_step_missing[c], on = out.camera_on_missing[c];
    if (c == 0) {
      EXPECT_LT(step, 3.0 * on);
      EXPECT_GT(on, 0.2);
    } else {
      EXPECT_GT(step, 0.3);
      EXPECT_LT(on, 0.1);
    }
  }
}

}  // namespace
}  // namespace drill_pipe_pose
