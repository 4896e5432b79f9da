#include "drill_pipe_pose/core/calibration/capture.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <memory>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"

namespace drill_pipe_pose::calibration {

namespace {

cv::Mat cameraMatrix(const Intrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

/// T_camera_target from the corners (solvePnP, iterative); false when it fails.
bool targetPose(const TargetGeometry& target, const CameraSetup& camera,
                const std::vector<CornerObservation>& corners, Eigen::Isometry3d* T) {
  const std::vector<Eigen::Vector3d> model = targetCorners(target);
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (const CornerObservation& c : corners) {
    const Eigen::Vector3d& p = model.at(static_cast<size_t>(c.id));
    obj.emplace_back(p.x(), p.y(), p.z());
    img.emplace_back(c.uv.x(), c.uv.y());
  }
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(obj, img, cameraMatrix(camera.intrinsics), camera.intrinsics.D, rvec, tvec))
    return false;
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(R, Re);
  T->linear() = Re;
  T->translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return T->translation().z() > 0;
}

enum class Print { kLight, kDark, kBoth };

/// Which print target point (x, y) lies on, at least `margin` from the other (kBoth: nearer).
Print printAt(const TargetTexture& texture, double x, double y, double margin) {
  int light = 0, dark = 0;
  for (const auto& [dx, dy] : {std::pair{0.0, 0.0}, {-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0},
                               {-1.0, 1.0}, {0.0, -1.0}, {0.0, 1.0}, {-1.0, 0.0}, {1.0, 0.0}}) {
    const double a = texture.albedo(x + dx * margin, y + dy * margin);
    (a < 0.5 ? dark : light) += 1;
  }
  return dark == 0 ? Print::kLight : light == 0 ? Print::kDark : Print::kBoth;
}

/// Every step-th element of `all`, so that at most `max_samples` are kept.
template <typename T>
std::vector<T> thinned(const std::vector<T>& all, int max_samples) {
  const size_t step =
      std::max<size_t>(1, (all.size() + max_samples - 1) / std::max(1, max_samples));
  std::vector<T> out;
  for (size_t i = 0; i < all.size(); i += step) out.push_back(all[i]);
  return out;
}

/// Depth pixels inside the projection of the shrunk outline (and on the white print, bias-corrected, when asked),
/// thinned evenly to at most max_samples, into obs->depth; with an amplitude image, the pixels
/// on either print as read with their amplitudes into obs->amplitude.
void sampleDepth(const TargetGeometry& target, const Intrinsics& k,
                 const Eigen::Isometry3d& T_depth_target, const DepthImage& depth,
                 const AmplitudeImage* amplitude, const CaptureOptions& options,
                 Observation* obs) {
  const Eigen::Vector2d half = targetSize(target) / 2.0 -
                               Eigen::Vector2d::Constant(target.square_length / 2.0);
  std::vector<cv::Point> outline;
  for (const auto& [sx, sy] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    const Eigen::Vector3d p = T_depth_target * Eigen::Vector3d(sx * half.x(), sy * half.y(), 0);
    if (p.z() <= 0) return;
    outline.emplace_back(static_cast<int>(std::lround(k.fx * p.x() / p.z() + k.cx)),
                         static_cast<int>(std::lround(k.fy * p.y() / p.z() + k.cy)));
  }
  cv::Mat mask = cv::Mat::zeros(static_cast<int>(depth.height), static_cast<int>(depth.width), CV_8U);
  cv::fillConvexPoly(mask, outline, cv::Scalar(255));
  // The target plane in the depth camera, to find where each pixel's ray meets the print.
  const Eigen::Isometry3d T_target_depth = T_depth_target.inverse();
  const Eigen::Vector3d n = T_depth_target.linear().col(2);
  const double d = n.dot(T_depth_target.translation());
  static thread_local std::unique_ptr<TargetTexture> texture;
  static thread_local TargetGeometry texture_of;
  if (      (!texture || texture_of.type != target.type || texture_of.squares_x != target.squares_x ||
       texture_of.squares_y != target.squares_y || texture_of.square_length != target.square_length ||
       texture_of.marker_length != target.marker_length || texture_of.dictionary != target.dictionary)) {
    texture = std::make_unique<TargetTexture>(target);
    texture_of = target;
  }
  std::vector<DepthSample> all;
  std::vector<AmplitudeSample> with_amplitude;
  const bool use_amplitude = amplitude && !amplitude->empty() &&
                             amplitude->width == depth.width && amplitude->height == depth.height;
  for (int v = 0; v < mask.rows; ++v)
    for (int u = 0; u < mask.cols; ++u) {
      if (!mask.at<uint8_t>(v, u)) continue;
      const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const Eigen::Vector3d p = T_target_depth * (ray * (d / n.dot(ray)));
      const Print print = printAt(*texture, p.x(), p.y(), options.edge_margin);
      if (print == Print::kBoth) continue;
      const float z = depth.depthAt(static_cast<uint32_t>(u), static_cast<uint32_t>(v));
      if (!(std::isfinite(z) && z > 0.0f)) continue;
      if (use_amplitude) {
        const float dn = amplitude->at(static_cast<uint32_t>(u), static_cast<uint32_t>(v));
        if (dn > 0.0f)
          with_amplitude.push_back({double(u), double(v), z, dn / options.amplitude_scale});
      }
      if (print != Print::kLight) continue;
      double z_read = z, sigma = 0.0, a = 0.0;
      if (options.weak_return_model) {
        // Amplitude a = r cos(incidence) / range^2 of the white print at this pixel (placed by
        // the PnP pose): how much nearer than the floor's bias it reads, and its noise.
        const double range = ray.norm() * d / n.dot(ray);
        const double cos_inc = std::abs(n.dot(ray.normalized()));
        a = options.light_reflectivity * cos_inc / (range * range);
        const kinect_v2::AmplitudeModel model;
        z_read += kinect_v2::weakReturnBias(model, model.bias_min_amplitude, 0.0) -
                  kinect_v2::weakReturnBias(model, a, 0.0);
        sigma = kinect_v2::amplitudeSigma(model, a);
      }
      all.push_back({double(u), double(v), z_read, sigma, a});
    }
  obs->depth = thinned(all, options.max_depth_samples);
  obs->amplitude = thinned(with_amplitude, options.max_depth_samples);
}

}  // namespace

Observation extractObservation(const TargetGeometry& target, const CameraSetup& camera,
                               const cv::Mat& gray, const DepthImage& depth, int placement,
                               double stamp, const CaptureOptions& options,
                               const AmplitudeImage* amplitude) {
  Observation obs;
  obs.camera = camera.name;
  obs.placement = placement;
  obs.stamp = stamp;
  std::vector<CornerObservation> corners = detectTarget(target, gray);
  if (static_cast<int>(corners.size()) < options.min_corners) return obs;
  obs.corners = std::move(corners);
  if (!camera.depth_intrinsics || depth.width == 0 || !depth.data) return obs;
  Eigen::Isometry3d T_camera_target = Eigen::Isometry3d::Identity();
  if (!targetPose(target, camera, obs.corners, &T_camera_target)) return obs;
  sampleDepth(target, *camera.depth_intrinsics, camera.T_camera_depth.inverse() * T_camera_target,
              depth, amplitude, options, &obs);
  return obs;
}

}  // namespace drill_pipe_pose::calibration
