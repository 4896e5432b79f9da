// detect_target: finds a calibration target (ChArUco or chessboard) in images and prints its
// corners, one line each: `IMAGE ID U V` (pixels, (0, 0) = centre of the top-left pixel).
//
//   detect_target --target charuco|chessboard --squares 5x7 --square 0.03 [--marker 0.022]
//       [--dictionary DICT_4X4_50] IMAGE...
//
// --squares counts printed squares (a board of 5 x 7 inner corners has 6 x 8 squares). Images
// may be 8-bit grey, colour, or 16-bit (a Kinect IR image: stretched to 8 bit between the 1st
// and 99th percentiles of its non-zero pixels). Chessboard corners come in OpenCV's order,
// ambiguous under a half turn of the board (core/calibration/target.hpp). A summary line per
// image goes to stderr. Exit status 0 (also when a target is not found); 1 on an unreadable
// image or an impossible target; 2 on a bad command line.
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "cli.hpp"

using namespace drill_pipe_pose;

namespace {

/// "5x7" -> (5, 7); false on anything else.
bool parseSquares(const std::string& s, int* x, int* y) {
  char sep = 0, extra = 0;
  return std::sscanf(s.c_str(), "%d%c%d%c", x, &sep, y, &extra) == 3 && (sep == 'x' || sep == 'X');
}

}  // namespace

int main(int argc, char** argv) {
  std::string type = "charuco", squares = "5x5";
  calibration::TargetGeometry target;
  std::vector<std::string> images;
  CLI::App app{"Finds a ChArUco or chessboard calibration target in images and prints its "
               "corners: IMAGE ID U V per line.",
               "detect_target"};
  tools::configureApp(app);
  app.add_option("--target", type, "target type")
      ->check(CLI::IsMember({"charuco", "chessboard"}))
      ->capture_default_str();
  app.add_option("--squares", squares, "printed squares, X x Y (e.g. 6x8)")->capture_default_str();
  app.add_option("--square", target.square_length, "[m] square side")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--marker", target.marker_length, "[m] ChArUco marker side")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--dictionary", target.dictionary, "ChArUco: OpenCV predefined dictionary")
      ->capture_default_str();
  app.add_option("IMAGE", images, "images (8-bit, colour or 16-bit)")
      ->required()
      ->check(CLI::ExistingFile);
  tools::parseOrExit(app, argc, argv);
  if (!parseSquares(squares, &target.squares_x, &target.squares_y))
    tools::usageError(app, "--squares: expected X x Y, e.g. 6x8; got \"" + squares + "\"");
  try {
    target.type = calibration::parseTargetType(type, "--target");
    calibration::validateTarget(target, "detect_target");
    for (const std::string& path : images) {
      const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
      if (raw.empty()) fail(path, ": cannot read the image");
      const cv::Mat gray = calibration::toDetectionGray(raw, path);
      const auto corners = calibration::detectTarget(target, gray);
      for (const auto& c : corners)
        std::printf("%s %d %.4f %.4f\n", path.c_str(), c.id, c.uv.x(), c.uv.y());
      std::fprintf(stderr, "%s: %dx%d, %zu corners\n", path.c_str(), gray.cols, gray.rows,
                   corners.size());
    }
  } catch (const InputError& e) {
    std::cerr << "detect_target: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
