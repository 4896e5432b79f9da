#include "drill_pipe_pose/core/calibration/capture.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>

#include "drill_pipe_pose/core/calibration/target.hpp"

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

/// Depth pixels inside the projection of the shrunk outline, on an even grid.
std::vector<DepthSample> sampleDepth(const TargetGeometry& target, const Intrinsics& k,
                                     const Eigen::Isometry3d& T_depth_target,
                                     const DepthImage& depth, int max_samples) {
  const Eigen::Vector2d half = targetSize(target) / 2.0 -
                               Eigen::Vector2d::Constant(target.square_length / 2.0);
  std::vector<cv::Point> outline;
  for (const auto& [sx, sy] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    const Eigen::Vector3d p = T_depth_target * Eigen::Vector3d(sx * half.x(), sy * half.y(), 0);
    if (p.z() <= 0) return {};
    outline.emplace_back(static_cast<int>(std::lround(k.fx * p.x() / p.z() + k.cx)),
                         static_cast<int>(std::lround(k.fy * p.y() / p.z() + k.cy)));
  }
  cv::Mat mask = cv::Mat::zeros(static_cast<int>(depth.height), static_cast<int>(depth.width), CV_8U);
  cv::fillConvexPoly(mask, outline, cv::Scalar(255));
  const int inside = cv::countNonZero(mask);
  if (inside == 0) return {};
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(
                                     static_cast<double>(inside) / std::max(1, max_samples)))));
  std::vector<DepthSample> out;
  for (int v = 0; v < mask.rows; v += stride)
    for (int u = 0; u < mask.cols; u += stride) {
      if (!mask.at<uint8_t>(v, u)) continue;
      const float z = depth.depthAt(static_cast<uint32_t>(u), static_cast<uint32_t>(v));
      if (std::isfinite(z) && z > 0.0f) out.push_back({double(u), double(v), double(z)});
    }
  return out;
}

}  // namespace

Observation extractObservation(const TargetGeometry& target, const CameraSetup& camera,
                               const cv::Mat& gray, const DepthImage& depth, int placement,
                               double stamp, const CaptureOptions& options) {
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
  obs.depth = sampleDepth(target, *camera.depth_intrinsics,
                          camera.T_camera_depth.inverse() * T_camera_target, depth,
                          options.max_depth_samples);
  return obs;
}

}  // namespace drill_pipe_pose::calibration
