// calibrate_rig: the rig file from what the cameras saw of the calibration target.
//
//   rosrun drill_pipe_pose calibrate_rig --observations OBS.yaml --out RIG.yaml
//   rosrun drill_pipe_pose calibrate_rig --bag BAG --config CAL.yaml --out RIG.yaml
//       [--image-topic hd/image_mono_rect] [--save-observations OBS.yaml]
//   both: [--depth-scale] [--intrinsics] [--no-depth] [--plain] [--min-placements N]
//       [--true-rig TRUE.yaml] [--report REPORT.yaml]
//
// OBS.yaml is an observations file (docs/calibration.md): written by --save-observations, by
// `simulate_calibration`, or by a script from another tool's corner files. BAG is a recording of
// launch/calibrate.launch (or simulate_bag --hd-mono): every camera's image + depth pairs are read
// (progress on stderr), the target is found in each (core/calibration/capture.hpp), frames taken
// while it moved are skipped and the still ones grouped into placements
// (core/calibration/placements.hpp); CAL.yaml (config/calibration/*.yaml) gives the target and the
// anchor (placement 0 = the first still placement). Prints a table per camera (placements, corners, reprojection rms, depth
// offset and its spread) and a verdict; with --true-rig, the errors against the truth.
// Exit status: 0 calibrated; 1 refused (the message names the camera and what to record);
// 2 bad command line; 3 calibrated but a camera's figures are outside the verdict's limits.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <set>
#include <string>

#include "drill_pipe_pose/core/calibration/placements.hpp"
#include "drill_pipe_pose/core/calibration/solver.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"
#include "drill_pipe_pose/ros/calibration_bag.hpp"
#include "cli.hpp"

using namespace drill_pipe_pose;
using namespace drill_pipe_pose::calibration;

namespace {

constexpr double kDeg = 180.0 / M_PI;

/// The verdict's limits per camera: corner rms [px] (a sharp corner in a Kinect v2 HD image:
/// 0.1-0.3 px on the simulator's calibration scene; beyond 0.5 px the images are blurred or the
/// intrinsics are off) and depth rms [m] (a Kinect v2 at 5-8 m: 5-15 mm).
constexpr double kGoodCornerRms = 0.5, kGoodDepthRms = 0.02;

/// Each camera's weak-return bias law from the target's two prints (only when the frames carried
/// amplitude): the B written to the rig file, or why the sensor's is kept.
void printWeakReturn(const CalibrationResult& r) {
  if (std::none_of(r.cameras.begin(), r.cameras.end(),
                   [](const CameraResult& c) { return c.weak_return.samples > 0; }))
    return;
  std::printf("weak-return bias B (the sensor's: %.4g m (1/m^2)^4), from the target's two prints:\n",
              kinect_v2::AmplitudeModel{}.bias_coeff);
  for (const CameraResult& c : r.cameras) {
    const WeakReturnFit& w = c.weak_return;
    if (w.samples == 0) {
      std::printf("  %-8s no amplitude samples: the sensor's law\n", c.name.c_str());
    } else if (w.fitted) {
      std::printf("  %-8s B %.4g +- %.2g from %d placements (a %.4f-%.4f 1/m^2, rms %.1f mm); "
                  "depth offset %.2f mm with it (%+.2f)\n",
                  c.name.c_str(), w.coeff, w.coeff_sigma, w.groups, w.amplitude_lo,
                  w.amplitude_hi, w.rms * 1e3, (c.depth_offset + w.offset_shift) * 1e3,
                  w.offset_shift * 1e3);
    } else {
      std::printf("  %-8s %s\n", c.name.c_str(), w.note.c_str());
    }
  }
}

bool printTable(const CalibrationResult& r, const ObservationSet& set) {
  std::printf("%-8s %10s %8s %9s %10s %13s %12s %9s\n", "camera", "placements", "corners",
              "rms [px]", "depth n", "offset [mm]", "scale", "rms [mm]");
  bool good = true;
  for (const CameraResult& c : r.cameras) {
    const bool ok = c.corner_rms_px <= kGoodCornerRms &&
                    (c.depth_samples == 0 || c.depth_rms <= kGoodDepthRms);
    good &= ok;
    std::printf("%-8s %10d %8d %9.3f %10d %13.2f %12.5f %9.2f%s\n", c.name.c_str(), c.placements,
                c.corners, c.corner_rms_px, c.depth_samples, c.depth_offset * 1e3, c.depth_scale,
                c.depth_rms * 1e3, ok ? "" : "   <- check");
  }
  std::printf("corner rms %.3f px over all; %zu observations rejected, %d corners dropped",
              r.corner_rms_px, r.rejected.size(), r.dropped_corners);
  if (set.target.type == TargetGeometry::Type::kChessboard)
    std::printf(", %d observations' corner order reversed", r.reversed_observations);
  std::printf("; solved in %.1f s\n", r.seconds);
  for (const auto& rej : r.rejected)
    std::printf("  rejected: %s placement %d: %s\n", rej.camera.c_str(), rej.placement,
                rej.reason.c_str());
  printWeakReturn(r);
  return good;
}

void printComparison(const RigComparison& cmp) {
  std::printf("\nagainst the true rig (after the best rigid alignment; anchoring apart):\n");
  std::printf("%-8s %14s %14s %16s %14s\n", "camera", "position [mm]", "rotation [deg]",
              "depth offset [mm]", "scale [%]");
  double max_t = 0, max_r = 0, max_d = 0, max_s = 0;
  for (const auto& c : cmp.cameras) {
    std::printf("%-8s %14.2f %14.4f %16.2f %14.3f\n", c.name.c_str(), c.translation_error * 1e3,
                c.rotation_error * kDeg, c.depth_offset_error * 1e3, c.depth_scale_error * 100);
    max_t = std::max(max_t, c.translation_error);
    max_r = std::max(max_r, c.rotation_error);
    max_d = std::max(max_d, std::abs(c.depth_offset_error));
    max_s = std::max(max_s, std::abs(c.depth_scale_error));
  }
  std::printf("max: position %.2f mm, rotation %.4f deg, depth offset %.2f mm, scale %.3f %%\n",
              max_t * 1e3, max_r * kDeg, max_d * 1e3, max_s * 100);
  std::printf("anchoring: %.2f mm, %.4f deg\n", cmp.anchor_translation * 1e3,
              cmp.anchor_rotation * kDeg);
}

void writeReport(const std::string& path, const CalibrationResult& r,
                 const std::optional<RigComparison>& cmp) {
  std::ofstream f(path);
  if (!f) fail("report file '", path, "' cannot be written");
  f << "seconds: " << r.seconds << "\ncorner_rms_px: " << r.corner_rms_px
    << "\nrejected: " << r.rejected.size() << "\nreversed: " << r.reversed_observations
    << "\ncameras:\n";
  for (size_t i = 0; i < r.cameras.size(); ++i) {
    const CameraResult& c = r.cameras[i];
    f << "  - {name: " << c.name << ", placements: " << c.placements
      << ", observations: " << c.observations << ", corners: " << c.corners
      << ", corner_rms_px: " << c.corner_rms_px << ", depth_offset: " << c.depth_offset
      << ", depth_scale: " << c.depth_scale << ", depth_rms: " << c.depth_rms
      << ", sigma_depth_offset: " << c.sigma_depth_offset << ", intrinsics: {fx: " << c.intrinsics.fx
      << ", fy: " << c.intrinsics.fy << ", cx: " << c.intrinsics.cx << ", cy: " << c.intrinsics.cy
      << ", D: [" << c.intrinsics.D[0] << ", " << c.intrinsics.D[1] << ", " << c.intrinsics.D[2]
      << ", " << c.intrinsics.D[3] << ", " << c.intrinsics.D[4] << "]}"
      << ", weak_return: {samples: " << c.weak_return.samples
      << ", fitted: " << (c.weak_return.fitted ? "true" : "false")
      << ", coeff: " << c.weak_return.coeff << ", coeff_sigma: " << c.weak_return.coeff_sigma
      << ", groups: " << c.weak_return.groups << ", offset_shift: " << c.weak_return.offset_shift
      << ", rms: " << c.weak_return.rms << "}";
    if (cmp)
      f << ", translation_error: " << cmp->cameras[i].translation_error
        << ", rotation_error: " << cmp->cameras[i].rotation_error
        << ", depth_offset_error: " << cmp->cameras[i].depth_offset_error
        << ", depth_scale_error: " << cmp->cameras[i].depth_scale_error;
    f << "}\n";
  }
  if (cmp)
    f << "anchor_translation: " << cmp->anchor_translation
      << "\nanchor_rotation: " << cmp->anchor_rotation << "\n";
}

void printIntrinsics(const CalibrationResult& r, const ObservationSet& set) {
  for (size_t c = 0; c < r.cameras.size(); ++c) {
    const Intrinsics &a = set.cameras[c].intrinsics, &b = r.cameras[c].intrinsics;
    std::printf("%s intrinsics: fx %.2f (%+.2f) fy %.2f (%+.2f) cx %.2f (%+.2f) cy %.2f (%+.2f)"
                " D [%.4f %.4f %.4f %.4f %.4f]\n",
                r.cameras[c].name.c_str(), b.fx, b.fx - a.fx, b.fy, b.fy - a.fy, b.cx, b.cx - a.cx,
                b.cy, b.cy - a.cy, b.D[0], b.D[1], b.D[2], b.D[3], b.D[4]);
  }
}

void writeRig(const std::string& path, const std::string& source, const CalibrationResult& r,
              const ObservationSet& set) {
  std::ofstream f(path);
  if (!f) fail("rig file '", path, "' cannot be written");
  f << "# Written by calibrate_rig from " << source << ": corner rms " << r.corner_rms_px
    << " px\n"
    << rigCalibrationToYaml(r.rig(set));
  std::printf("wrote %s\n", path.c_str());
}

/// The observations of a recorded calibration: the bag's frames, still ones grouped into
/// placements, up to `frames_per_placement` observations per camera and placement; CAL.yaml's
/// target and anchor.
ObservationSet observationsFromBag(const std::string& bag, const std::string& config,
                                   const CalibrationBagOptions& options, int frames_per_placement) {
  ObservationSet set = loadCalibrationConfig(config);
  std::fprintf(stderr, "calibrate_rig: reading %s\n", bag.c_str());
  const CalibrationBagFrames read = readCalibrationBag(
      bag, set.target, options,
      [](const std::string& line) { std::fprintf(stderr, "calibrate_rig: %s\n", line.c_str()); });
  set.cameras = read.cameras;
  if (set.anchor.camera && set.findCamera(*set.anchor.camera) < 0)
    fail(config, ": anchor camera '", *set.anchor.camera, "' is not in the bag ", bag);
  const PlacementGroups groups = groupPlacements(read.frames);
  set.observations = selectObservations(read.frames, groups, frames_per_placement);
  std::fprintf(stderr, "calibrate_rig: %d still placements (frame period %.3f s)\n", groups.count,
               groups.frame_period);
  for (size_t c = 0; c < set.cameras.size(); ++c) {
    int seen = 0, still = 0;
    for (size_t i = 0; i < read.frames.size(); ++i)
      if (read.frames[i].camera == set.cameras[c].name) {
        seen += !read.frames[i].corners.empty();
        still += groups.placement[i] >= 0;
      }
    std::set<int> distinct;
    for (const Observation& o : set.observations)
      if (o.camera == set.cameras[c].name) distinct.insert(o.placement);
    const int placements = static_cast<int>(distinct.size());
    std::fprintf(stderr,
                 "calibrate_rig: %s: %d frames, target in %d, still %d, at %d placements\n",
                 set.cameras[c].name.c_str(), read.frames_per_camera[c], seen, still, placements);
  }
  if (groups.count == 0)
    fail("bag '", bag, "': no still frame of the target in any camera (a frame is still when its "
         "corners agree with the camera's previous frame within 0.5 px)");
  return set;
}

}  // namespace

int main(int argc, char** argv) {
  std::string obs_path, bag_path, config_path, save_path, out_path, true_path, report_path;
  CalibrationBagOptions bag_opt;
  int frames_per_placement = 3;
  bool depth_scale = false, intrinsics = false, no_depth = false, plain = false;
  SolverOptions opt;
  CLI::App app{"Calibrates a rig (every camera's pose in the world, its depth offset) from an "
               "observations file of a calibration target, and writes the rig file.",
               "calibrate_rig"};
  tools::configureApp(app);
  auto* obs_opt = app.add_option("--observations", obs_path, "observations file (YAML)")
                      ->check(CLI::ExistingFile);
  auto* bag_o = app.add_option("--bag", bag_path,
                               "recorded calibration (launch/calibrate.launch) instead of "
                               "--observations")
                    ->check(CLI::ExistingFile)
                    ->excludes(obs_opt);
  app.add_option("--config", config_path,
                 "with --bag: calibration config (target and anchor), e.g. "
                 "config/calibration/thesis_lab.yaml")
      ->check(CLI::ExistingFile)
      ->needs(bag_o);
  app.add_option("--image-topic", bag_opt.image_topic,
                 "with --bag: the image the target is found in, relative to the camera")
      ->capture_default_str()
      ->needs(bag_o);
  app.add_option("--frames-per-placement", frames_per_placement,
                 "still frames per camera and placement used from a bag (each a measurement of "
                 "the same board pose; 3: a board held 2 s at the recorder's 2 Hz)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--amplitude-topic", bag_opt.amplitude_topic,
                 "with --bag: the IR amplitude image relative to the camera, for each camera's "
                 "weak-return bias law ('' to ignore it)")
      ->capture_default_str()
      ->needs(bag_o);
  bool no_weak_return = false;
  app.add_flag("--no-weak-return-model", no_weak_return,
               "with --bag: the depth has no Kinect v2 weak-return bias (another sensor, the "
               "simulator's ideal profile): depth samples are taken as read")
      ->needs(bag_o);
  app.add_option("--save-observations", save_path,
                 "with --bag: write the observations extracted from it (YAML)")
      ->needs(bag_o);
  app.add_option("--out", out_path, "rig file to write (YAML, the rig file schema)");
  app.add_flag("--depth-scale", depth_scale,
               "estimate each depth camera's scale too (an uncalibrated Kinect v2: ~2 %)");
  app.add_flag("--intrinsics", intrinsics, "estimate every camera's intrinsics too");
  app.add_flag("--no-depth", no_depth, "ignore depth samples (depth offsets stay 0)");
  bool no_weak_return_fit = false;
  app.add_flag("--no-weak-return-fit", no_weak_return_fit,
               "keep the sensor's weak-return bias law for every camera: do not learn a camera's "
               "own from the target's two prints (to compare with)");
  app.add_flag("--plain", plain,
               "plain least squares over every observation: no robust loss, no outlier pass "
               "(to compare with tools such as OpenCV's stereoCalibrate)");
  app.add_option("--min-placements", opt.min_placements,
                 "placements a camera must see the target in")
      ->check(CLI::PositiveNumber);
  app.add_option("--true-rig", true_path, "true rig file to score against (simulation)")
      ->check(CLI::ExistingFile);
  app.add_option("--report", report_path, "write the figures as YAML");
  tools::parseOrExit(app, argc, argv);
  bag_opt.capture.weak_return_model = !no_weak_return;
  if (obs_path.empty() == bag_path.empty() || (!bag_path.empty() && config_path.empty())) {
    std::fprintf(stderr, "calibrate_rig: give --observations OBS.yaml, or --bag BAG with "
                         "--config CAL.yaml\n");
    return 2;
  }
  opt.estimate_depth_scale = depth_scale;
  opt.estimate_intrinsics = intrinsics;
  opt.estimate_depth_offset = !no_depth;
  opt.robust = !plain;
  opt.fit_weak_return = !no_weak_return_fit;
  try {
    const std::string source = bag_path.empty() ? obs_path : bag_path;
    const ObservationSet set = bag_path.empty() ? loadObservations(obs_path)
                                                : observationsFromBag(bag_path, config_path, bag_opt,
                                                                     frames_per_placement);
    if (!save_path.empty()) saveObservations(set, save_path);
    std::fprintf(stderr, "calibrate_rig: %zu cameras, %zu observations from %s\n",
                 set.cameras.size(), set.observations.size(), source.c_str());
    const CalibrationResult r = calibrate(set, opt);
    const bool good = printTable(r, set);
    if (intrinsics) printIntrinsics(r, set);
    std::optional<RigComparison> cmp;
    if (!true_path.empty()) {
      cmp = compareRigs(r.rig(set), loadRigCalibration(true_path));
      printComparison(*cmp);
    }
    if (!out_path.empty()) writeRig(out_path, source, r, set);
    if (!report_path.empty()) writeReport(report_path, r, cmp);
    std::printf("verdict: %s\n", good ? "CALIBRATED" : "CALIBRATED, but check the marked cameras");
    return good ? 0 : 3;
  } catch (const InputError& e) {
    std::fprintf(stderr, "calibrate_rig: %s\n", e.what());
    std::printf("verdict: REFUSED\n");
    return 1;
  }
}
