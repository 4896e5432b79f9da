// render_board: renders simulated raw depth frames of a flat chessboard at given poses through the
// simulator's depth sensor model (sim::applyDepthEffects, the same pass as RigSimulator's), for
// scripts/sensor_check_lib.py (measure_frame) to measure exactly as it measures real Kinect v2
// frames of the board.
//
//   render_board --poses POSES.csv --out DIR [--profile kinect_v2_calibrated] [--off EFFECT ...]
//       [--sensor-param NAME=VALUE ...] [--edges-before-refit] [--seed 1] [--repeat 1]
//       [--fx --fy --cx --cy --width --height] [--cols 5 --rows 7] [--square 0.03]
//       [--margin 0.03] [--margin-reflectivity-ratio 1] [--dark-parity 1]
//       [--bright-reflectivity 0.6] [--dark-reflectivity 0.04] [--background-distance 0]
//       [--depth-offset 0]
//
// POSES.csv: header `frame,rx,ry,rz,tx,ty,tz`, one row per board pose in the depth camera's
// optical frame: OpenCV rvec (Rodrigues, rad) and tvec (m), p_cam = R(rvec) p_board + t. With
// the header `frame,rx,ry,rz,tx,ty,tz,bright_reflectivity,dark_reflectivity` each row also sets
// its squares' reflectivities (in [0, 1]; the sensor check gives each real frame's its fitted
// amplitude), overriding --bright-reflectivity / --dark-reflectivity; a tenth column
// `background_behind` [m] (> 0) puts a plane parallel to the board that far behind it (what the
// sensor check finds behind the real board's edges), in place of the --background-distance
// wall. Board frame: origin at the first inner corner, x along a row of `cols` corners, y along
// a column of `rows` corners, z the board normal. `frame` names the output files.
//
// Board: (cols + 1) x (rows + 1) printed squares, one square beyond the inner corners on every
// side, then a white margin. Square (i, j) = (floor(x / s), floor(y / s)) is dark when
// (i + j) mod 2 == dark parity. Background (--background-distance D > 0): a wall facing the
// camera (normal along the optical axis) D metres behind the board's centre along z; 0: no return
// outside the board.
//
// Writes DIR/<frame>.pgm (with --repeat N > 1: DIR/<frame>_<k>.pgm, k = 0..N-1): 16-bit binary
// PGM (P5, maxval 65535, big-endian) of the depth along z in millimetres, 0 = invalid; and
// DIR/corners.csv: `frame,i,u,v`, every inner corner (i = col + cols * row) projected with the
// pinhole (no distortion: the simulator renders rectified images). Row r of POSES.csv,
// realisation k draws its noise from the streams (seed, r, k): reproducible and independent of
// the other rows. The profile's random per-camera depth offset is not drawn: --depth-offset sets
// the offset. Exit status 0; 1 on a bad poses file or an unwritable folder; 2 on a bad command
// line.
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/sim/depth_effects.hpp"
#include "drill_pipe_pose/sim/random.hpp"
#include "drill_pipe_pose/sim/sensor_model.hpp"
#include "sim_cli.hpp"

using namespace drill_pipe_pose;
namespace fs = std::filesystem;

namespace {

struct Options {
  std::string poses, out, profile = "kinect_v2_calibrated";
  std::vector<std::string> off, sensor_params;
  bool edges_before_refit = false;
  uint64_t seed = 1;
  int repeat = 1;
  double fx, fy, cx, cy;  // defaults: the built-in Kinect v2 depth camera (parseArgs)
  int width, height;
  int cols = 5, rows = 7, dark_parity = 1;
  double square = 0.03, margin = 0.03, margin_ratio = 1.0;
  double bright_reflectivity = 0.6, dark_reflectivity = 0.04;
  double background_distance = 0.0, background_reflectivity = 0.3;
  double depth_offset_mm = 0.0;
};

/// The chessboard's printed layout and reflectivities.
struct Board {
  int cols, rows, dark_parity;
  double square, margin, margin_ratio;
  float bright, dark;

  /// Whether board point (x, y) lies on the board (squares or margin).
  bool contains(double x, double y) const {
    return x >= -square - margin && x <= cols * square + margin && y >= -square - margin &&
           y <= rows * square + margin;
  }
  /// Reflectivity at board point (x, y) on the board: dark or bright square, bright margin.
  float reflectivity(double x, double y) const {
    const int i = static_cast<int>(std::floor(x / square));
    const int j = static_cast<int>(std::floor(y / square));
    if (i < -1 || i > cols - 1 || j < -1 || j > rows - 1)
      return static_cast<float>(bright * margin_ratio);  // the margin
    return ((i + j) % 2 + 2) % 2 == dark_parity ? dark : bright;
  }
};

/// One row of the poses file.
struct BoardPose {
  std::string frame;
  Eigen::Isometry3d T_cam_board = Eigen::Isometry3d::Identity();
  double bright_reflectivity = -1, dark_reflectivity = -1;  ///< < 0: the options' values
  double background_behind = 0;  ///< [m] > 0: a plane parallel to the board this far behind it
};

Options parseArgs(int argc, char** argv) {
  Options o;
  const PinholeCamera kinect = sim::SensorIntrinsics::kinectV2().depth;
  o.fx = kinect.fx();
  o.fy = kinect.fy();
  o.cx = kinect.cx();
  o.cy = kinect.cy();
  o.width = static_cast<int>(kinect.imageWidth());
  o.height = static_cast<int>(kinect.imageHeight());
  CLI::App app{"Renders simulated raw depth frames (16-bit PGM, mm) of a chessboard at given "
               "poses through the simulator's depth sensor model, and the board's corners.",
               "render_board"};
  tools::configureApp(app);
  app.add_option("--poses", o.poses, "board poses: CSV frame,rx,ry,rz,tx,ty,tz (rvec, tvec [m])")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--out", o.out, "output folder (created if missing)")->required();
  app.add_option("--profile", o.profile,
                 "sensor profile: ideal|kinect_v2_calibrated|kinect_v2_field|"
                 "kinect_v2_uncalibrated")
      ->capture_default_str()
      ->check(tools::throwingCheck("PROFILE", [](const std::string& v) { sim::sensorProfile(v); }));
  tools::addEffectOffOption(app, "--off", &o.off,
                            "switch this sensor effect off (repeatable), e.g. axial_noise");
  tools::addSensorParamOption(app, "--sensor-param", &o.sensor_params,
                              "set one numeric sensor parameter (repeatable), e.g. "
                              "edge_invalid_probability=0.5");
  app.add_flag("--edges-before-refit", o.edges_before_refit,
               "the edge model before its fit to a real board's silhouette (docs/sensor_check.md)");
  app.add_option("--seed", o.seed, "random seed of the sensor noise")->capture_default_str();
  app.add_option("--repeat", o.repeat, "noise realisations per pose (> 1: <frame>_<k>.pgm)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--fx", o.fx, "[px] focal length x")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--fy", o.fy, "[px] focal length y")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--cx", o.cx, "[px] principal point x")->capture_default_str();
  app.add_option("--cy", o.cy, "[px] principal point y")->capture_default_str();
  app.add_option("--width", o.width, "[px] image width")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--height", o.height, "[px] image height")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--cols", o.cols, "inner corners along a board row (board x)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_option("--rows", o.rows, "inner corners along a board column (board y)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_option("--square", o.square, "[m] square side")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--margin", o.margin, "[m] white border beyond the outer squares")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--margin-reflectivity-ratio", o.margin_ratio,
                 "the margin's reflectivity over the bright squares'")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--dark-parity", o.dark_parity, "square (i, j) is dark when (i + j) mod 2 == P")
      ->capture_default_str()
      ->check(CLI::Range(0, 1));
  app.add_option("--bright-reflectivity", o.bright_reflectivity,
                 "reflectivity of the bright squares and the margin")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--dark-reflectivity", o.dark_reflectivity, "reflectivity of the dark squares")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--background-distance", o.background_distance,
                 "[m] wall this far behind the board's centre along z (0: no return)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--background-reflectivity", o.background_reflectivity,
                 "reflectivity of the background wall")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--depth-offset", o.depth_offset_mm, "[mm] added to every valid depth")
      ->capture_default_str();
  tools::parseOrExit(app, argc, argv);
  return o;
}

/// Reads the poses file; InputError names the file, the line and what is wrong.
std::vector<BoardPose> readPoses(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail(path, ": cannot read");
  std::string line;
  auto trim = [](std::string s) {
    s.erase(0, s.find_first_not_of(" \t\r"));
    s.erase(s.find_last_not_of(" \t\r") + 1);
    return s;
  };
  const std::string plain = "frame,rx,ry,rz,tx,ty,tz";
  const std::string with_refl = plain + ",bright_reflectivity,dark_reflectivity";
  const std::string with_back = with_refl + ",background_behind";
  if (!std::getline(f, line) ||
      (trim(line) != plain && trim(line) != with_refl && trim(line) != with_back))
    fail(path, ": the first line must be the header ", plain, ", ", with_refl, " or ", with_back,
         " (got \"", trim(line), "\")");
  const size_t fields = trim(line) == plain ? 7 : trim(line) == with_refl ? 9 : 10;
  std::vector<BoardPose> poses;
  std::set<std::string> seen;
  for (int n = 2; std::getline(f, line); ++n) {
    if (trim(line).empty()) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(trim(c));
    if (cells.size() != fields)
      fail(path, ":", n, ": expected ", fields, " fields, got ", cells.size());
    BoardPose p;
    p.frame = cells[0];
    if (p.frame.empty() || p.frame.find_first_of("/\\") != std::string::npos || p.frame == "." ||
        p.frame == "..")
      fail(path, ":", n, ": frame \"", p.frame, "\" is not a file name");
    if (!seen.insert(p.frame).second) fail(path, ":", n, ": frame \"", p.frame, "\" repeats");
    double x[9];
    for (size_t k = 0; k + 1 < fields; ++k) {
      size_t used = 0;
      try {
        x[k] = std::stod(cells[k + 1], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != cells[k + 1].size() || !std::isfinite(x[k]))
        fail(path, ":", n, ": field ", k + 2, " (\"", cells[k + 1], "\") is not a number");
    }
    const Eigen::Vector3d rvec(x[0], x[1], x[2]);
    const double angle = rvec.norm();
    if (angle > 0) p.T_cam_board.linear() = Eigen::AngleAxisd(angle, rvec / angle).matrix();
    p.T_cam_board.translation() = Eigen::Vector3d(x[3], x[4], x[5]);
    if (fields >= 9) {
      for (int k = 6; k < 8; ++k)
        if (x[k] < 0 || x[k] > 1)
          fail(path, ":", n, ": field ", k + 2, " (a reflectivity) must be in [0, 1], got ", x[k]);
      p.bright_reflectivity = x[6];
      p.dark_reflectivity = x[7];
    }
    if (fields == 10) {
      if (x[8] < 0)
        fail(path, ":", n, ": field 10 (background_behind, m) must be >= 0, got ", x[8]);
      p.background_behind = x[8];
    }
    poses.push_back(p);
  }
  if (poses.empty()) fail(path, ": no poses");
  return poses;
}

/// Per-pixel ray cast of the board (and the background wall) into the effects' inputs.
struct BoardScene {
  std::vector<float> z, cos_incidence, reflectivity, g2, ray_z;

  void cast(const Options& o, const Board& board, const Eigen::Isometry3d& T_cam_board,
            double background_behind, double max_incidence_rad) {
    const size_t n = static_cast<size_t>(o.width) * o.height;
    z.assign(n, 0.0f);
    cos_incidence.assign(n, 0.0f);
    reflectivity.assign(n, 0.0f);
    g2.assign(n, 0.0f);
    ray_z.assign(n, 1.0f);
    const Eigen::Matrix3d& R = T_cam_board.linear();
    const Eigen::Vector3d& t = T_cam_board.translation();
    const Eigen::Vector3d normal = R.col(2);
    const Eigen::Vector3d centre =
        T_cam_board * Eigen::Vector3d((o.cols - 1) * o.square / 2, (o.rows - 1) * o.square / 2, 0);
    const double z_wall = centre.z() + o.background_distance;
    // The plane parallel to the board, background_behind farther from the camera.
    const double plane_d = normal.dot(t);
    const double behind_d = plane_d + (plane_d >= 0 ? 1.0 : -1.0) * background_behind;
    for (int v = 0; v < o.height; ++v) {
      for (int u = 0; u < o.width; ++u) {
        const size_t i = static_cast<size_t>(v) * o.width + u;
        const Eigen::Vector3d ray =
            Eigen::Vector3d((u - o.cx) / o.fx, (v - o.cy) / o.fy, 1.0).normalized();
        ray_z[i] = static_cast<float>(ray.z());
        const double nr = normal.dot(ray);
        const double s = std::abs(nr) > 1e-12 ? normal.dot(t) / nr : -1.0;  // ray length to plane
        if (s > 0) {
          const Eigen::Vector3d q = R.transpose() * (s * ray - t);  // board coordinates
          if (board.contains(q.x(), q.y())) {
            set(i, s * ray.z(), std::abs(nr), board.reflectivity(q.x(), q.y()), max_incidence_rad);
            continue;
          }
        }
        if (background_behind > 0) {
          const double sb = std::abs(nr) > 1e-12 ? behind_d / nr : -1.0;
          if (sb > 0)
            set(i, sb * ray.z(), std::abs(nr), static_cast<float>(o.background_reflectivity),
                max_incidence_rad);
          continue;
        }
        if (o.background_distance > 0 && z_wall > 0)
          set(i, z_wall, ray.z(), static_cast<float>(o.background_reflectivity),
              max_incidence_rad);
      }
    }
  }

  void set(size_t i, double depth, double cos_theta, float refl, double max_incidence_rad) {
    const float c = static_cast<float>(cos_theta);
    z[i] = static_cast<float>(depth);
    cos_incidence[i] = c;
    reflectivity[i] = refl;
    g2[i] = sim::incidenceTerm(c, max_incidence_rad);
  }

  sim::DepthSceneView view(const Options& o) const {
    sim::DepthSceneView v;
    v.width = o.width;
    v.height = o.height;
    v.z = z.data();
    v.cos_incidence = cos_incidence.data();
    v.reflectivity = reflectivity.data();
    v.g2 = g2.data();
    v.ray_z = ray_z.data();
    return v;
  }
};

/// Writes a depth image as a 16-bit binary PGM of millimetres (big-endian, 0 = invalid).
void writePgm(const std::string& path, const DepthImage& img) {
  std::vector<uint8_t> bytes(static_cast<size_t>(img.width) * img.height * 2);
  for (uint32_t v = 0; v < img.height; ++v) {
    for (uint32_t u = 0; u < img.width; ++u) {
      const float m = img.depthAt(u, v);  // NaN when invalid; 16UC1 is exact in mm
      const long mm = m == m ? std::clamp(std::lround(m * 1000.0f), 0L, 65535L) : 0L;
      const size_t k = 2 * (static_cast<size_t>(v) * img.width + u);
      bytes[k] = static_cast<uint8_t>(mm >> 8);
      bytes[k + 1] = static_cast<uint8_t>(mm & 0xFF);
    }
  }
  std::ofstream f(path, std::ios::binary);
  f << "P5\n" << img.width << " " << img.height << "\n65535\n";
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) fail(path, ": cannot write");
}

/// Appends the pose's projected inner corners to corners.csv; InputError when one is not in
/// front of the camera.
void writeCorners(std::ofstream& csv, const Options& o, const BoardPose& pose) {
  char buf[160];
  for (int row = 0; row < o.rows; ++row) {
    for (int col = 0; col < o.cols; ++col) {
      const Eigen::Vector3d p =
          pose.T_cam_board * Eigen::Vector3d(col * o.square, row * o.square, 0);
      if (!(p.z() > 0))
        fail("frame ", pose.frame, ": inner corner ", col + o.cols * row,
             " is not in front of the camera (z = ", p.z(), " m)");
      std::snprintf(buf, sizeof(buf), "%s,%d,%.6f,%.6f\n", pose.frame.c_str(), col + o.cols * row,
                    o.fx * p.x() / p.z() + o.cx, o.fy * p.y() / p.z() + o.cy);
      csv << buf;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseArgs(argc, argv);
  try {
    sim::SensorEffects fx = sim::sensorProfile(o.profile);
    if (o.edges_before_refit) sim::useEdgeModelBeforeRefit(&fx);
    for (const std::string& e : o.off) sim::switchOffEffect(&fx, e);
    for (const std::string& p : o.sensor_params) sim::setEffectParameter(&fx, p);
    Board board{o.cols,
                      o.rows,
                      o.dark_parity,
                      o.square,
                      o.margin,
                      o.margin_ratio,
                      static_cast<float>(o.bright_reflectivity),
                      static_cast<float>(o.dark_reflectivity)};
    const std::vector<BoardPose> poses = readPoses(o.poses);
    std::error_code ec;
    fs::create_directories(o.out, ec);
    if (!fs::is_directory(o.out)) fail(o.out, ": cannot create the output folder");
    std::ofstream corners(o.out + "/corners.csv");
    if (!corners) fail(o.out, "/corners.csv: cannot write");
    corners << "frame,i,u,v\n";
    const double max_inc = fx.max_incidence_deg * M_PI / 180.0;
    BoardScene scene;
    size_t written = 0;
    for (size_t r = 0; r < poses.size(); ++r) {
      if (poses[r].bright_reflectivity >= 0) {
        board.bright = static_cast<float>(poses[r].bright_reflectivity);
        board.dark = static_cast<float>(poses[r].dark_reflectivity);
      }
      scene.cast(o, board, poses[r].T_cam_board, poses[r].background_behind, max_inc);
      for (int k = 0; k < o.repeat; ++k) {
        DepthImage img;
        sim::applyDepthEffects(fx, scene.view(o), o.depth_offset_mm * 1e-3, 1.0,
                               sim::streamSeed(o.seed, sim::kStreamDepthNoise, r, k),
                               sim::streamSeed(o.seed, sim::kStreamInterference, r, k), &img);
        const std::string name =
            o.repeat > 1 ? poses[r].frame + "_" + std::to_string(k) : poses[r].frame;
        writePgm(o.out + "/" + name + ".pgm", img);
        ++written;
      }
      writeCorners(corners, o, poses[r]);
      if ((r + 1) % 10 == 0)
        std::fprintf(stderr, "render_board: %zu / %zu poses\n", r + 1, poses.size());
    }
    if (!corners.flush()) fail(o.out, "/corners.csv: cannot write");
    std::printf("render_board: %zu frames of %zu poses (profile %s) in %s\n", written, poses.size(),
                o.profile.c_str(), o.out.c_str());
  } catch (const InputError& e) {
    std::cerr << "render_board: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
