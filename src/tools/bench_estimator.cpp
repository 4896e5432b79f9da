// bench_estimator: the core pipeline on a bag, single-threaded (unless --threads), without ROS
// transport: per-cycle time (median, p95, p99), peak RSS and accuracy against the bag's ground
// truth.
//
//   rosrun drill_pipe_pose bench_estimator BAG [--method ours|thesis_baseline] [--max-cycles N]
//       [--config estimator.yaml-like params are not read here: defaults + --work-zone]
//       [--csv errors.csv] [--label NAME] [--skip-camera CAM] [--no-temporal] [--no-tracking]
//       [--threads N] [--vote-fraction F] [--box-reach M] [--confirmations N]
//       [--no-silhouette-points] [--incidence-noise C]
//
// --skip-camera leaves one camera's frames out (a dead camera); --no-temporal turns the temporal
// filter off; --no-tracking makes every cycle run the full decision (with both, each cycle
// stands alone); --threads sets EstimatorConfig::threads (default 1; the node's default is 2);
// --vote-fraction sets carving.vote_fraction (the node's carving/vote_fraction; default 0.75);
// --box-reach sets carving.box_reach (the node's carving/box_reach; default 0.5 m, 0 = off);
// --confirmations sets temporal.confirmations (default 1, 0 = a jump restarts the filter at once);
// --no-silhouette-points sets profile_fit.silhouette_points false; --incidence-noise sets
// profile_fit.incidence_noise (default 0 = off).
// Invalid ends are counted by reason.
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
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"
#include "drill_pipe_pose/core/evaluation.hpp"
#include "drill_pipe_pose/core/frame_sync.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"

using namespace drill_pipe_pose;

namespace {

void usage() {
  std::cerr << "usage: bench_estimator BAG [--method ours|thesis_baseline] [--max-cycles N] "
               "[--work-zone x0 y0 z0 x1 y1 z1] [--csv FILE] [--label NAME] [--skip-camera CAM] [--no-temporal] [--no-tracking] "
               "[--threads N] [--vote-fraction F] [--box-reach M] [--confirmations N] "
               "[--no-silhouette-points] [--incidence-noise C]\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::string bag_path, csv_path, label, method = "ours", skip_camera;
  size_t max_cycles = 0;
  EstimatorConfig cfg;
  cfg.work_zone.min = Eigen::Vector3d(2.7, 4.0, 0.0);  // config/estimator_thesis_lab.yaml
  cfg.work_zone.max = Eigen::Vector3d(6.7, 8.1, 3.0);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        usage();
        std::exit(2);
      }
      return argv[++i];
    };
    // An option's value as a number; a clear message and exit 2 when it is not one.
    auto number = [&]() -> double {
      const std::string v = next();
      size_t used = 0;
      double x = 0;
      try {
        x = std::stod(v, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != v.size()) {
        std::cerr << "bench_estimator: " << a << " expects a number, got '" << v << "'\n";
        std::exit(2);
      }
      return x;
    };
    auto count = [&]() -> long {
      const double x = number();
      if (!(x >= 0) || x != std::floor(x) || x > 1e9) {
        std::cerr << "bench_estimator: " << a << " expects a whole number >= 0, got " << x
                  << "\n";
        std::exit(2);
      }
      return static_cast<long>(x);
    };
    if (a == "--method")
      method = next();
    else if (a == "--max-cycles")
      max_cycles = static_cast<size_t>(count());
    else if (a == "--csv")
      csv_path = next();
    else if (a == "--label")
      label = next();
    else if (a == "--skip-camera")
      skip_camera = next();
    else if (a == "--no-temporal")
      cfg.temporal.enabled = false;
    else if (a == "--no-tracking")
      cfg.tracking.enabled = false;
    else if (a == "--threads")
      cfg.threads = static_cast<int>(count());
    else if (a == "--vote-fraction")
      cfg.carving.vote_fraction = number();
    else if (a == "--box-reach")
      cfg.carving.box_reach = number();
    else if (a == "--confirmations")
      cfg.temporal.confirmations = static_cast<int>(count());
    else if (a == "--no-silhouette-points")
      cfg.profile_fit.silhouette_points = false;
    else if (a == "--incidence-noise")
      cfg.profile_fit.incidence_noise = number();
    else if (a == "--work-zone") {
      for (int k = 0; k < 3; ++k) cfg.work_zone.min[k] = number();
      for (int k = 0; k < 3; ++k) cfg.work_zone.max[k] = number();
    } else if (bag_path.empty())
      bag_path = a;
    else {
      usage();
      return 2;
    }
  }
  if (bag_path.empty()) {
    usage();
    return 2;
  }
  try {
    cfg.method = parseEstimatorMethod(method, "--method");
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
