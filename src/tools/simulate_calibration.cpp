// simulate_calibration: the observations of a simulated rig calibration. For every placement of
// the scene's calibration target and every camera, renders the HD colour image (1920x1080) and
// the depth image at the middle of the placement's hold (and the frames after it with
// --frames-per-placement N), finds the target (core/calibration/capture.hpp) and writes the
// observations file; --true-rig writes the rig the simulator rendered with (the answer).
//
//   simulate_calibration --rig config/rigs/thesis_lab.yaml --scene config/scenes/calibration.yaml
//       [--profile kinect_v2_calibrated] [--seed 1] --out obs.yaml [--true-rig true.yaml]
//       [--frames-per-placement 1] [--sensors config/sensors]
//
// Anchor: placement 0 at its world pose (the scene file's surveyed floor mark). Progress and a
// per-camera summary (placements found, corners) go to stderr. Exit status 0; 1 on a bad input
// file or a scene without calibration_target; 2 on a bad command line.
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/calibration/capture.hpp"
#include "drill_pipe_pose/core/calibration/target.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"
#include "sim_cli.hpp"

using namespace drill_pipe_pose;
namespace cal = drill_pipe_pose::calibration;

namespace {

/// Renders and extracts every (placement, camera, frame); prints progress and the coverage.
cal::ObservationSet capture(sim::RigSimulator& sim, const sim::CalibrationTargetConfig& tc,
                            int frames, const cal::CaptureOptions& options) {
  cal::ObservationSet set;
  set.world_frame = sim.worldFrame();
  set.target = tc.geometry;
  set.anchor.placement = 0;
  set.anchor.T_world_anchor = tc.placements.at(0);
  for (size_t i = 0; i < sim.numCameras(); ++i) {
    cal::CameraSetup c;
    c.name = sim.cameraName(i);
    c.intrinsics = cal::intrinsicsFromCameraInfo(sim.colorInfo(i), c.name + " colour");
    c.depth_intrinsics = cal::intrinsicsFromCameraInfo(sim.depthInfo(i), c.name + " depth");
    c.T_camera_depth = sim.T_link_depth(i);
    set.cameras.push_back(c);
  }
  std::vector<int> seen(sim.numCameras(), 0), corners(sim.numCameras(), 0);
  double render_s = 0;
  int rendered = 0;
  const double period = 1.0 / sim.sensor(0).frame_rate_hz;
  for (size_t k = 0; k < tc.placements.size(); ++k) {
    std::cerr << "placement " << k + 1 << "/" << tc.placements.size() << "\n";
    for (size_t i = 0; i < sim.numCameras(); ++i)
      for (int j = 0; j < frames; ++j) {
        const double t = tc.holdMiddle(k) + j * period;
        const auto t0 = std::chrono::steady_clock::now();
        const sim::RigSimulator::Frame f = sim.render(i, t, k * 64 + static_cast<uint64_t>(j));
        render_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ++rendered;
        const cv::Mat bgr(static_cast<int>(f.color_height), static_cast<int>(f.color_width),
                          CV_8UC3, const_cast<uint8_t*>(f.bgr.data()));
        cv::Mat gray;
        cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
        cal::Observation ob = cal::extractObservation(tc.geometry, set.cameras[i], gray,
                                                      f.sensor_frame.depth, static_cast<int>(k),
                                                      t, options, &f.sensor_frame.amplitude);
        if (ob.corners.empty()) continue;
        if (j == 0) ++seen[i];
        corners[i] += static_cast<int>(ob.corners.size());
        set.observations.push_back(std::move(ob));
      }
  }
  for (size_t i = 0; i < sim.numCameras(); ++i)
    std::fprintf(stderr, "%s: target found at %d of %zu placements, %d corners\n",
                 sim.cameraName(i).c_str(), seen[i], tc.placements.size(), corners[i]);
  std::fprintf(stderr, "%.2f s per rendered frame (HD colour + depth), %d frames\n",
               render_s / std::max(rendered, 1), rendered);
  return set;
}

}  // namespace

int main(int argc, char** argv) {
  std::string rig = "config/rigs/thesis_lab.yaml", scene, out, true_rig;
  int frames = 1;
  std::vector<std::string> effects_off, sensor_params;
  cal::CaptureOptions capture_options;
  bool no_weak_return = false;
  sim::SimulatorOptions opt;
  opt.color = true;
  opt.color_scale = 2;  // the Kinect v2's HD colour image
  opt.simulated_detection = false;
  CLI::App app{"Simulates a rig calibration: renders each camera at each placement of the "
               "scene's calibration target and writes the corners and depth samples found.",
               "simulate_calibration"};
  tools::configureApp(app);
  app.add_option("--rig", rig, "rig calibration file (the true camera poses)")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
  app.add_option("--scene", scene, "scene file with a calibration_target")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--profile", opt.profile, "sensor profile")
      ->capture_default_str()
      ->check(tools::throwingCheck("PROFILE", [](const std::string& v) { sim::sensorProfile(v); }));
  app.add_option("--seed", opt.seed, "random seed of the simulation")->capture_default_str();
  app.add_option("--out", out, "observations file to write (YAML)")->required();
  app.add_option("--true-rig", true_rig, "also write the true rig (YAML)");
  app.add_option("--frames-per-placement", frames, "consecutive frames per camera and placement")
      ->capture_default_str()
      ->check(CLI::Range(1, 30));
  app.add_option("--sensors", opt.sensor_config_dir, "folder of the sensor intrinsics files");
  app.add_flag("--no-weak-return-model", no_weak_return,
               "the depth has no Kinect v2 weak-return bias (the ideal profile, another sensor): "
               "depth samples are taken as read");
  tools::addEffectOffOption(app, "--effect-off", &effects_off,
                            "switch one of the profile's sensor effects off by name (repeatable), "
                            "to see what each costs the calibration");
  tools::addSensorParamOption(app, "--sensor-param", &sensor_params,
                              "set one numeric sensor parameter of the profile (repeatable), e.g. "
                              "lateral_noise_px=0.8");
  tools::parseOrExit(app, argc, argv);
  try {
    if (!effects_off.empty() || !sensor_params.empty()) {
      sim::SensorEffects fx = sim::sensorProfile(opt.profile);
      for (const std::string& e : effects_off) sim::switchOffEffect(&fx, e);
      for (const std::string& p : sensor_params) sim::setEffectParameter(&fx, p);
      opt.effects = fx;
    }
    auto sim = sim::loadScenario(rig, scene, opt);
    const sim::SceneConfig cfg = sim::loadSceneConfig(scene);
    if (!cfg.calibration_target) fail(scene, ": no calibration_target");
    capture_options.weak_return_model = !no_weak_return;
    const cal::ObservationSet set =
        capture(*sim, *cfg.calibration_target, frames, capture_options);
    cal::saveObservations(set, out);
    if (!true_rig.empty()) {
      std::ofstream f(true_rig);
      if (!f) fail(true_rig, ": cannot write");
      f << rigCalibrationToYaml(sim->trueRig());
    }
  } catch (const InputError& e) {
    std::cerr << "simulate_calibration: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
