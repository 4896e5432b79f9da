#include "drill_pipe_pose/core/calibration/target.hpp"

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose::calibration {

namespace {

// OpenCV's predefined dictionaries by name, with the number of markers each holds.
struct DictionaryInfo {
  int id;
  int size;
};

const std::map<std::string, DictionaryInfo>& dictionaries() {
  using namespace cv::aruco;
  static const std::map<std::string, DictionaryInfo> table = {
      {"DICT_4X4_50", {DICT_4X4_50, 50}},         {"DICT_4X4_100", {DICT_4X4_100, 100}},
      {"DICT_4X4_250", {DICT_4X4_250, 250}},      {"DICT_4X4_1000", {DICT_4X4_1000, 1000}},
      {"DICT_5X5_50", {DICT_5X5_50, 50}},         {"DICT_5X5_100", {DICT_5X5_100, 100}},
      {"DICT_5X5_250", {DICT_5X5_250, 250}},      {"DICT_5X5_1000", {DICT_5X5_1000, 1000}},
      {"DICT_6X6_50", {DICT_6X6_50, 50}},         {"DICT_6X6_100", {DICT_6X6_100, 100}},
      {"DICT_6X6_250", {DICT_6X6_250, 250}},      {"DICT_6X6_1000", {DICT_6X6_1000, 1000}},
      {"DICT_7X7_50", {DICT_7X7_50, 50}},         {"DICT_7X7_100", {DICT_7X7_100, 100}},
      {"DICT_7X7_250", {DICT_7X7_250, 250}},      {"DICT_7X7_1000", {DICT_7X7_1000, 1000}},
      {"DICT_ARUCO_ORIGINAL", {DICT_ARUCO_ORIGINAL, 1024}},
  };
  return table;
}

cv::Ptr<cv::aruco::CharucoBoard> charucoBoard(const TargetGeometry& t) {
  return cv::aruco::CharucoBoard::create(
      t.squares_x, t.squares_y, static_cast<float>(t.square_length),
      static_cast<float>(t.marker_length),
      cv::aruco::getPredefinedDictionary(dictionaries().at(t.dictionary).id));
}

/// OpenCV's board frame (origin at the top-left corner of the drawn board, x right, y down the
/// drawing, z into the print) to ours (origin at the centre, y up the print, z out of it): a
/// half turn about x and a shift by half the size.
Eigen::Vector3d fromBoardFrame(const TargetGeometry& t, double X, double Y) {
  const Eigen::Vector2d half = targetSize(t) / 2.0;
  return {X - half.x(), half.y() - Y, 0.0};
}

/// Chessboard: the printed view (row 0 at the top of the print), square (i, j) black when
/// i + j is even, as OpenCV draws a ChArUco board.
cv::Mat drawChessboard(const TargetGeometry& t, int pps) {
  cv::Mat img(t.squares_y * pps, t.squares_x * pps, CV_8U, cv::Scalar(255));
  for (int j = 0; j < t.squares_y; ++j)
    for (int i = 0; i < t.squares_x; ++i)
      if ((i + j) % 2 == 0) img(cv::Rect(i * pps, j * pps, pps, pps)).setTo(0);
  return img;
}

/// Refinement half-window of a chessboard as a fraction of a square: chosen on the synthetic
/// renders of test_calibration (squares of 30-120 px): wide enough to average the edge noise,
/// inside the square.
constexpr double kChessboardWindow = 1.0 / 3.0;

std::vector<CornerObservation> toObservations(const std::vector<cv::Point2f>& pts,
                                              const std::vector<int>& ids) {
  std::vector<CornerObservation> out(pts.size());
  for (size_t k = 0; k < pts.size(); ++k) {
    out[k].id = ids.empty() ? static_cast<int>(k) : ids[k];
    out[k].uv = Eigen::Vector2d(pts[k].x, pts[k].y);
  }
  return out;
}

/// Half-window of the final corner refinement [px]: `fraction` of the smallest distance between
/// two neighbouring detected corners (one square), within [2, 10].
int refineHalfWindow(const std::vector<cv::Point2f>& pts, const std::vector<int>& ids,
                     int row_length, double fraction) {
  double best = 1e9;
  for (size_t a = 0; a < pts.size(); ++a)
    for (size_t b = a + 1; b < pts.size(); ++b) {
      const int da = ids.empty() ? static_cast<int>(a) : ids[a];
      const int db = ids.empty() ? static_cast<int>(b) : ids[b];
      const bool neighbours = (std::abs(da - db) == 1 && da / row_length == db / row_length) ||
                              std::abs(da - db) == row_length;
      if (neighbours) best = std::min(best, static_cast<double>(cv::norm(pts[a] - pts[b])));
    }
  if (best > 1e8) return 3;
  return std::clamp(static_cast<int>(best * fraction), 2, 10);
}

void refineCorners(const cv::Mat& gray, std::vector<cv::Point2f>* pts, const std::vector<int>& ids,
                   int row_length, double fraction) {
  if (pts->empty()) return;
  const int w = refineHalfWindow(*pts, ids, row_length, fraction);
  // 0.001 px / 100 iterations: converged far below the 0.1 px the tests ask for.
  cv::cornerSubPix(gray, *pts, cv::Size(w, w), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 0.001));
}

std::vector<CornerObservation> detectCharuco(const TargetGeometry& t, const cv::Mat& gray) {
  const auto board = charucoBoard(t);
  std::vector<int> marker_ids;
  std::vector<std::vector<cv::Point2f>> marker_corners, rejected;
  const auto params = cv::aruco::DetectorParameters::create();
  cv::aruco::detectMarkers(gray, board->dictionary, marker_corners, marker_ids, params, rejected);
  if (marker_ids.empty()) return {};
  // Markers missed at first (blur, steep views) found again where the board says they are.
  cv::aruco::refineDetectedMarkers(gray, board, marker_corners, marker_ids, rejected);
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board, corners, ids);
  if (ids.empty()) return {};
  // The window stays inside the white gap between a corner and its markers (the square's
  // (1 - marker / square) / 2), so that the markers' edges do not pull the corner.
  const double gap = (1.0 - t.marker_length / t.square_length) / 2.0;
  refineCorners(gray, &corners, ids, t.squares_x - 1, std::min(kChessboardWindow, 0.8 * gap));
  return toObservations(corners, ids);
}

std::vector<CornerObservation> detectChessboard(const TargetGeometry& t, const cv::Mat& gray) {
  const cv::Size pattern(t.squares_x - 1, t.squares_y - 1);
  std::vector<cv::Point2f> corners;
  // No CALIB_CB_FAST_CHECK: it rejected 8 of the 10 real Kinect v2 IR images
  // (scripts/calibration_real_data) that the full search finds; the sector-based detector is the
  // fallback.
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE;
  if (!cv::findChessboardCorners(gray, pattern, corners, flags) &&
      !cv::findChessboardCornersSB(gray, pattern, corners))
    return {};
  refineCorners(gray, &corners, {}, pattern.width, kChessboardWindow);
  return toObservations(corners, {});
}

}  // namespace

void validateTarget(const TargetGeometry& t, const std::string& where) {
  const bool charuco = t.type == TargetGeometry::Type::kCharuco;
  // findChessboardCorners needs at least 3 x 3 inner corners; a ChArUco board 2 x 2 squares.
  const int min_squares = charuco ? 2 : 4;
  if (t.squares_x < min_squares)
    fail(where, ": squares_x = ", t.squares_x, ": at least ", min_squares, " squares needed");
  if (t.squares_y < min_squares)
    fail(where, ": squares_y = ", t.squares_y, ": at least ", min_squares, " squares needed");
  if (t.squares_x > kMaxTargetSquares || t.squares_y > kMaxTargetSquares)
    fail(where, ": squares ", t.squares_x, " x ", t.squares_y, ": at most ", kMaxTargetSquares,
         " squares per side");
  if (!(t.square_length > 0.0) || !std::isfinite(t.square_length))
    fail(where, ": square_length = ", t.square_length, ": must be a positive length [m]");
  if (!charuco) return;
  if (!(t.marker_length > 0.0) || !std::isfinite(t.marker_length))
    fail(where, ": marker_length = ", t.marker_length, ": must be a positive length [m]");
  if (t.marker_length >= t.square_length)
    fail(where, ": marker_length = ", t.marker_length, ": must be smaller than square_length (",
         t.square_length, ")");
  const auto it = dictionaries().find(t.dictionary);
  if (it == dictionaries().end())
    fail(where, ": dictionary = \"", t.dictionary,
         "\": not an OpenCV predefined dictionary (e.g. DICT_4X4_50)");
  const int markers = t.squares_x * t.squares_y / 2;
  if (markers > it->second.size)
    fail(where, ": dictionary = ", t.dictionary, " holds ", it->second.size, " markers, the ",
         t.squares_x, " x ", t.squares_y, " board needs ", markers);
}

std::vector<Eigen::Vector3d> targetCorners(const TargetGeometry& t) {
  validateTarget(t, "targetCorners");
  std::vector<Eigen::Vector3d> out;
  if (t.type == TargetGeometry::Type::kCharuco) {
    const auto board = charucoBoard(t);
    for (const cv::Point3f& p : board->chessboardCorners)
      out.push_back(fromBoardFrame(t, p.x, p.y));
    return out;
  }
  // Row-major from the top-left inner corner of the printed view, as OpenCV's ChArUco ids.
  for (int j = 1; j < t.squares_y; ++j)
    for (int i = 1; i < t.squares_x; ++i)
      out.push_back(fromBoardFrame(t, i * t.square_length, j * t.square_length));
  return out;
}

Eigen::Vector2d targetSize(const TargetGeometry& t) {
  return {t.squares_x * t.square_length, t.squares_y * t.square_length};
}

TargetTexture::TargetTexture(const TargetGeometry& target, int pixels_per_square) {
  validateTarget(target, "TargetTexture");
  if (pixels_per_square < 8)
    fail("TargetTexture: pixels_per_square = ", pixels_per_square, ": at least 8");
  const int pps = pixels_per_square;
  cv::Mat printed;  // as seen from the front: row 0 at the top of the print (target +y)
  if (target.type == TargetGeometry::Type::kCharuco)
    charucoBoard(target)->draw(cv::Size(target.squares_x * pps, target.squares_y * pps), printed,
                               0, 1);
  else
    printed = drawChessboard(target, pps);
  cv::flip(printed, image_, 0);  // row index along target +y
  pixels_per_metre_ = pps / target.square_length;
  half_size_ = targetSize(target) / 2.0;
}

double TargetTexture::albedo(double x, double y) const {
  const double c = std::floor((x + half_size_.x()) * pixels_per_metre_);
  const double r = std::floor((y + half_size_.y()) * pixels_per_metre_);
  if (c < 0 || r < 0 || c >= image_.cols || r >= image_.rows) return -1.0;
  return image_.at<uint8_t>(static_cast<int>(r), static_cast<int>(c)) / 255.0;
}

std::vector<CornerObservation> detectTarget(const TargetGeometry& target, const cv::Mat& gray) {
  validateTarget(target, "detectTarget");
  if (gray.empty() || gray.type() != CV_8UC1)
    fail("detectTarget: the image must be 8-bit grey (CV_8UC1), got type ", gray.type(), " ",
         gray.cols, "x", gray.rows);
  return target.type == TargetGeometry::Type::kCharuco ? detectCharuco(target, gray)
                                                       : detectChessboard(target, gray);
}

cv::Mat toDetectionGray(const cv::Mat& image, const std::string& source) {
  if (image.empty()) fail(source, ": empty image");
  if (image.type() == CV_8UC1) return image;
  cv::Mat gray;
  if (image.type() == CV_8UC3 || image.type() == CV_8UC4) {
    cv::cvtColor(image, gray, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
    return gray;
  }
  if (image.type() != CV_16UC1)
    fail(source, ": image type ", image.type(), " (", image.channels(),
         " channels): expected 8-bit grey, BGR or 16-bit grey");
  std::vector<uint16_t> values;
  values.reserve(image.total());
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c)
      if (const uint16_t v = image.at<uint16_t>(r, c)) values.push_back(v);
  if (values.empty()) fail(source, ": the 16-bit image is all zero");
  // 1st / 99th percentiles: a few saturated or dead pixels (IR speckle) do not set the scale.
  auto nth = [&](double q) {
    auto it = values.begin() + static_cast<std::ptrdiff_t>(q * (values.size() - 1));
    std::nth_element(values.begin(), it, values.end());
    return static_cast<double>(*it);
  };
  const double lo = nth(0.01), hi = std::max(nth(0.99), lo + 1.0);
  image.convertTo(gray, CV_8U, 255.0 / (hi - lo), -lo * 255.0 / (hi - lo));
  return gray;
}

TargetGeometry::Type parseTargetType(const std::string& name, const std::string& source) {
  if (name == "charuco") return TargetGeometry::Type::kCharuco;
  if (name == "chessboard") return TargetGeometry::Type::kChessboard;
  fail(source, ": target type \"", name, "\": expected charuco or chessboard");
}

}  // namespace drill_pipe_pose::calibration
