// bench_estimator: the core pipeline on a bag, single-threaded (unless --threads), without ROS
// transport: per-cycle time (median, p95, p99), peak RSS and accuracy against the bag's ground
// truth.
//
//   rosrun drill_pipe_pose bench_estimator BAG [--method ours|thesis_baseline] [--max-cycles N]
//       [--work-zone x0 y0 z0 x1 y1 z1] [--csv errors.csv] [--label NAME] [--skip-camera CAM]
//       [--no-temporal] [--no-tracking] [--threads N] [--vote-fraction F] [--box-reach M]
//       [--confirmations N] [--no-silhouette-points] [--incidence-noise C]
//
// The estimator starts from EstimatorConfig's defaults with the thesis lab's work zone
// (config/estimator_thesis_lab.yaml; another one only through --work-zone) and 1 thread; no
// configuration file is read. Each option below that is given then overrides one entry:
// --work-zone sets work_zone; --no-temporal turns the temporal filter off; --no-tracking makes
// every cycle run the full decision (with both, each cycle stands alone); --threads sets
// EstimatorConfig::threads (default 1; the node's default is 2); --vote-fraction sets
// carving.vote_fraction (the node's carving/vote_fraction; default 0.75); --box-reach sets
// carving.box_reach (the node's carving/box_reach; default 0.5 m, 0 = off); --confirmations sets
// temporal.confirmations (default 1, 0 = a jump restarts the filter at once);
// --no-silhouette-points sets profile_fit.silhouette_points false; --incidence-noise sets
// profile_fit.incidence_noise (default 0 = off).
// --skip-camera leaves one camera's frames out (a dead camera). Invalid ends are counted by
// reason. Exit status 0; 1 on a bad bag or configuration; 2 on a bad command line.
//
// Cycles are formed exactly as the node forms them (FrameSynchronizer), with each frame arriving
// 10 ms after its capture stamp. TF comes from the bag's /tf_static and /tf.
#include <cctype>
#include <drill_pipe_pose/SensorFrame.h>
#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sys/resource.h>
#include <tf2/buffer_core.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <array>
#include <functional>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"
#include "drill_pipe_pose/core/evaluation.hpp"
#include "drill_pipe_pose/core/frame_sync.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "cli.hpp"

using namespace drill_pipe_pose;

namespace {

/// The command line. Estimator settings are collected as overrides and applied in makeConfig(),
/// after the bench's defaults, so that other sources (a configuration file, generic key=value
/// parameters) can be layered in between without touching the options themselves.
struct BenchOptions {
  std::string bag_path, csv_path, label, method = "ours", skip_camera;
  size_t max_cycles = 0;
  /// One entry per estimator option given, each setting its field(s).
  std::vector<std::function<void(EstimatorConfig&)>> overrides;
};

/// The bench's starting point: EstimatorConfig's defaults with the thesis lab's work zone.
EstimatorConfig benchDefaults() {
  EstimatorConfig cfg;
  cfg.work_zone.min = Eigen::Vector3d(2.7, 4.0, 0.0);  // config/estimator_thesis_lab.yaml
  cfg.work_zone.max = Eigen::Vector3d(6.7, 8.1, 3.0);
  return cfg;
}

/// The configuration the bench runs: its defaults, then the command line's overrides.
EstimatorConfig makeConfig(const BenchOptions& o) {
  EstimatorConfig cfg = benchDefaults();
  for (const auto& apply : o.overrides) apply(cfg);
  cfg.method = parseEstimatorMethod(o.method, "--method");
  return cfg;
}

template <class T>
std::string str(const T& v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// Adds an estimator option `name` of type T whose value, when given, `set` writes into the
/// configuration; the usage shows `def` as its default.
template <class T, class Set>
CLI::Option* addOverride(CLI::App& app, BenchOptions& o, const std::string& name, const T& def,
                         const std::string& description, Set set) {
  auto given = [&o, set](const T& v) {
    o.overrides.push_back([v, set](EstimatorConfig& c) { set(c, v); });
  };
  return app.add_option_function<T>(name, given, description)->default_str(str(def));
}

/// Adds an estimator flag `name` that applies `set` when given.
template <class Set>
CLI::Option* addOverrideFlag(CLI::App& app, BenchOptions& o, const std::string& name,
                             const std::string& description, Set set) {
  return app.add_flag_function(
      name, [&o, set](int64_t) { o.overrides.push_back(set); }, description);
}

BenchOptions parseArgs(int argc, char** argv) {
  BenchOptions o;
  const EstimatorConfig d = benchDefaults();
  CLI::App app{"Runs the estimator's core pipeline on a bag without ROS transport: time per "
               "cycle, peak memory and accuracy against the bag's ground truth.",
               "bench_estimator"};
  tools::configureApp(app);
  app.footer("Starts from the estimator's defaults with the thesis lab's work zone and 1 thread "
             "(the node's default is 2); reads no configuration file. Cycles are formed as the "
             "node forms them; TF comes from the bag.");
  app.add_option("BAG", o.bag_path, "bag with SensorFrames, /tf_static and the ground truth")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--method", o.method, "estimator method: ours|thesis_baseline")
      ->capture_default_str()
      ->check(tools::throwingCheck("METHOD", [](const std::string& v) {
        parseEstimatorMethod(v, "--method");
      }));
  app.add_option("--max-cycles", o.max_cycles, "stop after N cycles (0: the whole bag)")
      ->capture_default_str()
      ->check(CLI::Range(size_t{0}, size_t{1000000000}));
  app.add_option("--csv", o.csv_path, "write the per-estimate errors to this CSV file");
  app.add_option("--label", o.label, "name of the run in the report (default: the bag's path)");
  app.add_option("--skip-camera", o.skip_camera, "leave this camera's frames out (a dead camera)");
  app.add_option_function<std::vector<double>>(
         "--work-zone",
         [&o](const std::vector<double>& v) {
           const std::string bad = tools::boxError(v);
           if (!bad.empty()) throw CLI::ValidationError("--work-zone", bad);
           o.overrides.push_back([v](EstimatorConfig& c) {
             c.work_zone.min = Eigen::Vector3d(v[0], v[1], v[2]);
             c.work_zone.max = Eigen::Vector3d(v[3], v[4], v[5]);
           });
         },
         "[m] work_zone: min and max corner (default: the thesis lab's, " +
             str(d.work_zone.min.transpose()) + "  " + str(d.work_zone.max.transpose()) + ")")
      ->expected(6)
      ->option_text("x0 y0 z0 x1 y1 z1");
  addOverrideFlag(app, o, "--no-temporal", "turn the temporal filter off (temporal.enabled)",
                  [](EstimatorConfig& c) { c.temporal.enabled = false; });
  addOverrideFlag(app, o, "--no-tracking", "run the full decision every cycle (tracking.enabled)",
                  [](EstimatorConfig& c) { c.tracking.enabled = false; });
  addOverride(app, o, "--threads", d.threads, "threads of the estimator (threads)",
              [](EstimatorConfig& c, int v) { c.threads = v; })
      ->check(CLI::Range(1, 256));
  addOverride(app, o, "--vote-fraction", d.carving.vote_fraction,
              "fraction of the cameras that must agree (carving.vote_fraction)",
              [](EstimatorConfig& c, double v) { c.carving.vote_fraction = v; })
      ->check(CLI::Range(0.0, 1.0));
  addOverride(app, o, "--box-reach", d.carving.box_reach,
              "[m] carving votes only near a box (carving.box_reach, 0 = off)",
              [](EstimatorConfig& c, double v) { c.carving.box_reach = v; })
      ->check(CLI::NonNegativeNumber);
  addOverride(app, o, "--confirmations", d.temporal.confirmations,
              "cycles that confirm a jump (temporal.confirmations, 0 = restart at once)",
              [](EstimatorConfig& c, int v) { c.temporal.confirmations = v; })
      ->check(CLI::Range(0, 1000));
  addOverrideFlag(app, o, "--no-silhouette-points",
                  "no silhouette points in the final fit (profile_fit.silhouette_points)",
                  [](EstimatorConfig& c) { c.profile_fit.silhouette_points = false; });
  addOverride(app, o, "--incidence-noise", d.profile_fit.incidence_noise,
              "grazing-incidence depth noise term (profile_fit.incidence_noise, 0 = off)",
              [](EstimatorConfig& c, double v) { c.profile_fit.incidence_noise = v; })
      ->check(CLI::NonNegativeNumber);
  tools::parseOrExit(app, argc, argv);
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const BenchOptions opt = parseArgs(argc, argv);
  const std::string &bag_path = opt.bag_path, &csv_path = opt.csv_path, &label = opt.label,
                    &method = opt.method, &skip_camera = opt.skip_camera;
  const size_t max_cycles = opt.max_cycles;
  try {
    const EstimatorConfig cfg = makeConfig(opt);
    rosbag::Bag bag;
    try {
      bag.open(bag_path, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
      fail("cannot open bag '", bag_path, "': ", e.what());
    }
    // Pass 1: TF, ground truth, the camera list.
    tf2::BufferCore tf(ros::Duration(3600.0));
    std::array<GroundTruthTrack, kNumEnds> truth;
    std::set<std::string> cameras;
    for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
      const std::string& topic = m.getTopic();
      if (topic == "/tf_static" || topic == "/tf") {
        if (auto msg = m.instantiate<tf2_msgs::TFMessage>())
          for (const auto& t : msg->transforms) tf.setTransform(t, "bag", topic == "/tf_static");
      } else if (auto sf = m.instantiate<SensorFrame>()) {
        if (sf->camera != skip_camera) cameras.insert(sf->camera);
      } else {
        for (EndLabel e : {EndLabel::kBoxEnd, EndLabel::kPinEnd})
          if (topic == conventions::groundTruthTopic(e))
            if (auto p = m.instantiate<geometry_msgs::PoseStamped>()) {
              Eigen::Isometry3d T;
              tf2::fromMsg(p->pose, T);
              truth[static_cast<int>(e)].add(toNs(p->header.stamp), T);
            }
      }
    }
    if (cameras.empty()) fail("bag '", bag_path, "' has no SensorFrames");

    // Pass 2: cycles through the core.
    PoseEstimator estimator(cfg);
    FrameSynchronizer sync(std::vector<std::string>(cameras.begin(), cameras.end()),
                           FrameSyncConfig());
    std::map<uint64_t, SensorFrameConstPtr> store;
    std::vector<double> times_ms;
    std::array<std::vector<double>, 4> stage_ms;  // cut-out, fusion, segmentation, registration
    std::vector<EstimateSample> estimates;
    std::map<std::string, size_t> reasons;  // why an end was invalid, counted
    uint64_t next_id = 0;
    size_t cycles = 0, bad = 0;
    auto run = [&](const FrameSynchronizer::Cycle& c) {
      if (max_cycles && cycles >= max_cycles) return;
      std::vector<CameraInput> inputs;
      const auto t0 = std::chrono::steady_clock::now();
      for (const auto& [cam, id] : c.frames) {
        CameraInput in;
        try {
          in.frame = fromMsg(store.at(id));
          const ros::Time stamp = fromNs(in.frame.depth_stamp_ns);
          in.T_world_depth =
              tf2::transformToEigen(tf.lookupTransform("world", in.frame.depth_frame_id, stamp));
          in.T_color_depth = tf2::transformToEigen(
              tf.lookupTransform(in.frame.frame_id, in.frame.depth_frame_id, stamp));
        } catch (const std::exception& e) {
          if (bad++ < 5)
            std::cerr << "bench_estimator: skipping a frame of " << cam << ": " << e.what() << "\n";
          continue;
        }
        inputs.push_back(std::move(in));
      }
      const CycleResult r = estimator.process(inputs);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      times_ms.push_back(ms);
      stage_ms[0].push_back(r.timing.cutout_ms);
      stage_ms[1].push_back(r.timing.fusion_ms);
      stage_ms[2].push_back(r.timing.segmentation_ms);
      stage_ms[3].push_back(r.timing.registration_ms);
      for (int e = 0; e < kNumEnds; ++e) {
        EstimateSample s;
        s.stamp_ns = c.stamp_ns;
        s.label = static_cast<EndLabel>(e);
        s.valid = r.ends[e].valid;
        s.T_world_end = r.ends[e].T_world_end;
        s.covariance = r.ends[e].covariance;
        estimates.push_back(s);
        if (!r.ends[e].valid) {
          // Reasons with their numbers as '#' (at most 110 characters), counted.
          std::string why;
          const std::string& rs = r.ends[e].reason;
          for (size_t i = 0; i < rs.size() && why.size() < 110; ++i) {
            if (std::isdigit(static_cast<unsigned char>(rs[i]))) {
              while (i + 1 < rs.size() && (std::isdigit(static_cast<unsigned char>(rs[i + 1])) ||
                                           rs[i + 1] == '.' || rs[i + 1] == 'e'))
                ++i;
              why += '#';
            } else {
              why += rs[i];
            }
          }
          ++reasons[std::string(labelName(s.label)) + ": " + why];
        }
      }
      ++cycles;
    };
    int64_t first_stamp = 0, last_stamp = 0;
    for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
      auto sf = m.instantiate<SensorFrame>();
      if (!sf || sf->camera == skip_camera) continue;
      const int64_t stamp = toNs(sf->header.stamp);
      if (!first_stamp) first_stamp = stamp;
      last_stamp = std::max(last_stamp, stamp);
      const uint64_t id = next_id++;
      store[id] = sf;
      sync.add(sf->camera, stamp, stamp * 1e-9 + 0.010, id);
      for (const auto& c : sync.poll(stamp * 1e-9 + 0.010)) {
        run(c);
        for (const auto& f : c.frames) store.erase(f.second);
      }
      for (auto id2 : sync.takeDropped()) store.erase(id2);
      if (max_cycles && cycles >= max_cycles) break;
    }
    for (const auto& c : sync.poll(1e18)) run(c);

    EvaluationOptions eo;
    // Expected cycles: 30 per second of input actually processed.
    const int64_t span_ns = max_cycles && cycles >= max_cycles && !estimates.empty()
                                ? estimates.back().stamp_ns - first_stamp
                                : last_stamp - first_stamp;
    eo.expected_cycles = std::max<size_t>(cycles, std::llround(span_ns * 1e-9 * 30.0));
    const auto evals = evaluate(truth, estimates, eo);
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    std::cout << std::fixed << std::setprecision(2);
    std::cout << "== " << (label.empty() ? bag_path : label) << " | method " << method << " | "
              << cameras.size() << " cameras | " << cycles << " cycles\n";
    std::cout << "time per cycle [ms]: median " << percentile(times_ms, 0.5) << ", p95 "
              << percentile(times_ms, 0.95) << ", p99 " << percentile(times_ms, 0.99) << ", max "
              << percentile(times_ms, 1.0) << " | peak RSS " << ru.ru_maxrss / 1024.0 << " MB\n";
    std::cout << "stage medians [ms]: cut-out " << percentile(stage_ms[0], 0.5) << ", fusion "
              << percentile(stage_ms[1], 0.5) << ", segmentation " << percentile(stage_ms[2], 0.5)
              << ", registration " << percentile(stage_ms[3], 0.5) << "\n";
    printEvaluation(evals, std::cout);
    for (const auto& [why, n] : reasons) std::cout << "invalid " << n << "x: " << why << "\n";
    // One machine-readable line per end for scripts/bench.
    for (const auto& ev : evals) {
      if (!ev.present) continue;
      const auto& s = ev.stats;
      std::cout << "RESULT label=" << (label.empty() ? bag_path : label) << " method=" << method
                << " end=" << labelName(ev.label) << " cycles=" << cycles
                << " expected=" << s.expected_cycles << " estimates=" << s.estimates
                << std::setprecision(3) << " median_ms=" << percentile(times_ms, 0.5)
                << " p95_ms=" << percentile(times_ms, 0.95)
                << " p99_ms=" << percentile(times_ms, 0.99) << " rss_mb=" << ru.ru_maxrss / 1024.0
                << " mean_err_mm=" << s.mean_position_error * 1e3
                << " std_x_mm=" << s.std_position.x() * 1e3
                << " std_y_mm=" << s.std_position.y() * 1e3
                << " std_z_mm=" << s.std_position.z() * 1e3
                << " mean_axis_deg=" << s.mean_axis_angle * 180 / M_PI
                << " within_1cm_1deg=" << s.fractionWithin(0.01, M_PI / 180)
                << " within_2cm_2deg=" << s.fractionWithin(0.02, 2 * M_PI / 180)
                << " in_3sigma=" << ev.within_3sigma
                << " axis_in_3sigma=" << ev.axis_within_3sigma << "\n";
    }
    if (!csv_path.empty()) {
      std::ofstream f(csv_path);
      if (!f) fail("cannot write '", csv_path, "'");
      writeErrorCsv(evals, f);
    }
  } catch (const InputError& e) {
    std::cerr << "bench_estimator: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
