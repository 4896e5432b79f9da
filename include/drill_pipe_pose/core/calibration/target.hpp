#pragma once
// The calibration target: where its corners are, what it looks like (for the simulator and for
// printing), and finding it in an image. ROS-free; uses OpenCV (aruco, calib3d).
//
// Target frame (see observations.hpp): origin at the centre of the printed squares, x along
// squares_x, y along squares_y, z out of the printed face; the corners lie at z = 0.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/calibration/observations.hpp"

namespace drill_pipe_pose::calibration {

/// Throws InputError naming `where` and the field for an impossible geometry (non-positive, too
/// few or more than kMaxTargetSquares squares, marker not smaller than the square, unknown
/// dictionary, more markers than the dictionary holds).
void validateTarget(const TargetGeometry& target, const std::string& where);

/// Corner positions in the target frame, indexed by corner id (CornerObservation::id).
/// ChArUco: OpenCV's ChArUco corner ids. Chessboard: the (squares_x-1) x (squares_y-1) inner
/// corners in the order detectTarget returns them.
std::vector<Eigen::Vector3d> targetCorners(const TargetGeometry& target);

/// Outer size of the printed squares [m] (x, y).
Eigen::Vector2d targetSize(const TargetGeometry& target);

/// The printed face: albedo in [0, 1] (0 black, 1 white) at target-frame point (x, y) [m];
/// -1 outside the printed squares. Built once from OpenCV's drawing of the board at
/// `pixels_per_square` resolution; lookups are nearest-pixel.
class TargetTexture {
 public:
  TargetTexture(const TargetGeometry& target, int pixels_per_square = 60);
  double albedo(double x, double y) const;
  /// The drawn image (8-bit grey), pixel (0, 0) at target (-size.x/2, -size.y/2).
  const cv::Mat& image() const { return image_; }

 private:
  cv::Mat image_;
  double pixels_per_metre_ = 0.0;
  Eigen::Vector2d half_size_ = Eigen::Vector2d::Zero();
};

/// Finds the target in an 8-bit grey image: corner ids and sub-pixel positions (OpenCV's pixel
/// convention: (0, 0) is the centre of the top-left pixel). Empty when not found.
/// Chessboard: the corners in OpenCV's order (findChessboardCorners), which is ambiguous under a
/// half turn of the board (and a quarter turn for a square pattern): id k may be the corner
/// targetCorners()[n - 1 - k]. The solver resolves it (the pose that fits the other cameras).
std::vector<CornerObservation> detectTarget(const TargetGeometry& target, const cv::Mat& gray);

/// An image as detectTarget wants it: 8-bit grey. 8-bit grey is returned as is, BGR / BGRA are
/// converted, 16-bit (e.g. a Kinect IR image) is stretched linearly so that the 1st..99th
/// percentiles of its non-zero pixels span 0..255. Throws InputError naming `source` otherwise.
cv::Mat toDetectionGray(const cv::Mat& image, const std::string& source);

/// "charuco" | "chessboard" (InputError naming `source` otherwise).
TargetGeometry::Type parseTargetType(const std::string& name, const std::string& source);

}  // namespace drill_pipe_pose::calibration
