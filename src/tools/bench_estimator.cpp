// bench_estimator: what the pose_estimator node would publish for a bag, without ROS transport:
// the same cycle runner (frame synchronisation, input assembly with the bag's TF, estimator,
// output policy) as the node, with the node's defaults (2 threads). Prints the time per cycle
// (median, p95, p99), peak RSS and the accuracy of the published poses against the bag's ground
// truth; optionally every cycle's published poses (--cycles-csv).
//
//   rosrun drill_pipe_pose bench_estimator BAG [--config FILE] [--param KEY=VALUE]...
//       [--method ours|thesis_baseline] [--max-cycles N] [--csv errors.csv]
//       [--cycles-csv cycles.csv] [--poses-bag poses.bag] [--label NAME] [--skip-camera CAM]
//       [--rig RIG_FILE] [shortcuts, see --help]
//
// Configuration, in this order: the node's defaults; --config (the YAML file the node loads,
// e.g. config/estimator_thesis_lab.yaml; its cameras are replaced by the bag's); the shortcut
// options (--work-zone, --threads, --no-temporal, --rig ...); then every --param, any key of the
// pose_estimator parameter table (docs/parameters.md), e.g. --param carving/vote_fraction=0.6.
// "Valid" is the node's: a pose no older than max_pose_age (fresh or the last one repeated).
// Cycles are formed as the node forms them, each frame arriving 10 ms after its capture stamp.
// --poses-bag writes the node's /drill_pipe_pose/pipe_ends messages of every cycle (what
// `rosbag record /drill_pipe_pose/pipe_ends` records from the node), e.g. for label_from_poses.
// Exit status 0; 1 on a bad bag or configuration; 2 on a bad command line.
#include <drill_pipe_pose/SensorFrame.h>
#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>
#include <sys/resource.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "cli.hpp"
#include "drill_pipe_pose/core/cycle_runner.hpp"
#include "drill_pipe_pose/ros/estimator_params.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/evaluation.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/tf_source.hpp"

using namespace drill_pipe_pose;

namespace {

struct BenchOptions {
  std::string bag_path, csv_path, cycles_csv_path, poses_bag_path, label, config_path,
      skip_camera;
  size_t max_cycles = 0;
  /// key=value settings in the order they apply: the shortcuts', then --param's.
  std::vector<std::pair<std::string, std::string>> shortcuts, params;
};

/// Checks a KEY=VALUE against the pose_estimator parameter table (key, type, range) while the
/// command line is parsed, so that a bad one exits 2 naming the option.
void checkParam(const std::string& option, const std::string& key, const std::string& value) {
  EstimatorNodeConfig scratch;
  try {
    applyParamString(estimatorNodeParamTable(), &scratch, key, value, option);
  } catch (const InputError& e) {
    throw CLI::ValidationError(option, e.what());
  }
}

/// A shortcut option that sets one parameter table key.
void addShortcut(CLI::App& app, BenchOptions& o, const std::string& name, const std::string& key,
                 const std::string& description) {
  app.add_option_function<std::string>(
      name,
      [&o, key, name](const std::string& v) {
        checkParam(name, key, v);
        o.shortcuts.emplace_back(key, v);
      },
      description + " (--param " + key + "=VALUE)");
}

/// A shortcut flag that sets one parameter table key to `value`.
void addShortcutFlag(CLI::App& app, BenchOptions& o, const std::string& name,
                     const std::string& key, const std::string& value,
                     const std::string& description) {
  app.add_flag_function(
      name, [&o, key, value](int64_t) { o.shortcuts.emplace_back(key, value); },
      description + " (--param " + key + "=" + value + ")");
}

BenchOptions parseArgs(int argc, char** argv) {
  BenchOptions o;
  CLI::App app{"Runs what the pose_estimator node runs on a bag, without ROS transport: time per "
               "cycle, peak memory and the accuracy of the published poses.",
               "bench_estimator"};
  tools::configureApp(app);
  app.footer(
      "Configuration: the node's defaults, then --config, then the shortcuts, then every --param "
      "(any key of the pose_estimator parameter table). \"Valid\" is the node's: a pose no older "
      "than max_pose_age. Cycles are formed as the node forms them; TF comes from the bag.");
  app.add_option("BAG", o.bag_path, "bag with SensorFrames, /tf_static and the ground truth")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--config", o.config_path,
                 "the node's YAML configuration (e.g. config/estimator_thesis_lab.yaml)")
      ->check(CLI::ExistingFile);
  tools::addKeyValueOption(app, "--param", &o.params, checkParam,
                           "set one parameter, e.g. carving/vote_fraction=0.6 (repeatable)");
  app.add_option("--max-cycles", o.max_cycles, "stop after N cycles (0: the whole bag)")
      ->capture_default_str()
      ->check(CLI::Range(size_t{0}, size_t{1000000000}));
  app.add_option("--csv", o.csv_path, "write the per-estimate errors to this CSV file");
  app.add_option("--cycles-csv", o.cycles_csv_path,
                 "write every cycle's published ends (stamp, cameras, valid, pose, pipe type and "
                 "its probabilities) to this CSV");
  app.add_option("--poses-bag", o.poses_bag_path,
                 "write every cycle's pipe_ends message (as the node publishes it, topic "
                 "/drill_pipe_pose/pipe_ends) to this bag");
  app.add_option("--label", o.label, "name of the run in the report (default: the bag's path)");
  app.add_option("--skip-camera", o.skip_camera, "leave this camera's frames out (a dead camera)");
  addShortcut(app, o, "--method", "method", "estimator method: ours|thesis_baseline");
  app.add_option_function<std::vector<double>>(
         "--work-zone",
         [&o](const std::vector<double>& v) {
           const std::string bad = tools::boxError(v);
           if (!bad.empty()) throw CLI::ValidationError("--work-zone", bad);
           std::ostringstream lo, hi;
           lo.precision(17), hi.precision(17);
           lo << "[" << v[0] << ", " << v[1] << ", " << v[2] << "]";
           hi << "[" << v[3] << ", " << v[4] << ", " << v[5] << "]";
           checkParam("--work-zone", "work_zone/min", lo.str());
           checkParam("--work-zone", "work_zone/max", hi.str());
           o.shortcuts.emplace_back("work_zone/min", lo.str());
           o.shortcuts.emplace_back("work_zone/max", hi.str());
         },
         "[m] work zone's min and max corner (--param work_zone/min=[x0,y0,z0] ...)")
      ->expected(6)
      ->option_text("x0 y0 z0 x1 y1 z1");
  addShortcut(app, o, "--rig", "rig",
              "rig file whose depth_offset / depth_scale correct each camera's depth (e.g. "
              "simulate_bag --true-rig's)");
  addShortcut(app, o, "--threads", "threads", "threads of the estimator");
  addShortcutFlag(app, o, "--no-temporal", "temporal/enabled", "false", "no temporal filter");
  addShortcutFlag(app, o, "--no-tracking", "tracking/enabled", "false",
                  "run the full decision every cycle");
  addShortcut(app, o, "--vote-fraction", "carving/vote_fraction",
              "fraction of the cameras that must agree");
  addShortcut(app, o, "--box-reach", "carving/box_reach", "[m] carving votes only near a box");
  addShortcut(app, o, "--confirmations", "temporal/confirmations", "cycles that confirm a jump");
  addShortcutFlag(app, o, "--no-silhouette-points", "profile_fit/silhouette_points", "false",
                  "no silhouette points in the final fit");
  addShortcut(app, o, "--incidence-noise", "profile_fit/incidence_noise",
              "grazing-incidence depth noise term (0 = off)");
  tools::parseOrExit(app, argc, argv);
  return o;
}

/// What the bag holds besides the frames: TF, ground truth, the cameras.
struct BagContents {
  TfTransforms tf;
  std::array<GroundTruthTrack, kNumEnds> truth;
  TrueEnds true_ends;  ///< every true end per stamp (several of one label: several pipes)
  std::vector<TrueJoint> joints;  ///< the joints as rendered (simulate_bag's bags; else empty)
  std::set<std::string> cameras;
};

void readBagContents(rosbag::Bag& bag, const std::string& skip_camera, BagContents* out) {
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    const std::string& topic = m.getTopic();
    if (topic == "/tf_static" || topic == "/tf") {
      if (auto msg = m.instantiate<tf2_msgs::TFMessage>())
        for (const auto& t : msg->transforms) out->tf.add(t, topic == "/tf_static");
    } else if (auto sf = sensorFrameOf(m)) {
      if (sf->camera != skip_camera) out->cameras.insert(sf->camera);
    } else if (topic == conventions::kGroundTruthJointsTopic) {
      if (auto s = m.instantiate<std_msgs::String>()) out->joints = parseTrueJoints(s->data);
    } else {
      for (EndLabel e : {EndLabel::kBoxEnd, EndLabel::kPinEnd})
        if (topic == conventions::groundTruthTopic(e))
          if (auto p = m.instantiate<geometry_msgs::PoseStamped>()) {
            Eigen::Isometry3d T;
            tf2::fromMsg(p->pose, T);
            out->truth[static_cast<int>(e)].add(toNs(p->header.stamp), T);
            out->true_ends[static_cast<int>(e)][toNs(p->header.stamp)].push_back(T.translation());
          }
    }
  }
}

/// The node's configuration for this bag: defaults, --config, shortcuts, --param; the bag's
/// cameras.
EstimatorNodeConfig makeConfig(const BenchOptions& o, const std::set<std::string>& cameras) {
  EstimatorNodeConfig cfg;
  cfg.cameras.assign(cameras.begin(), cameras.end());
  if (!o.config_path.empty()) loadEstimatorNodeYaml(&cfg, o.config_path);
  cfg.cameras.assign(cameras.begin(), cameras.end());
  for (const auto& [key, value] : o.shortcuts)
    applyParamString(estimatorNodeParamTable(), &cfg, key, value, "bench_estimator");
  for (const auto& [key, value] : o.params)
    applyParamString(estimatorNodeParamTable(), &cfg, key, value, "--param");
  defaultPipeCatalog(&cfg.estimator);
  validateEstimatorNodeConfig(cfg);
  return cfg;
}

/// Invalid ends' reasons with their numbers as '#' (at most 110 characters), for counting.
std::string reasonPattern(const std::string& rs) {
  std::string why;
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
  return why;
}

/// What the bench collects from the cycles.
struct Tally {
  size_t cycles = 0, problems = 0;
  std::vector<double> times_ms;
  // cut-out, fusion, segmentation, registration, and of registration the edge scans
  std::array<std::vector<double>, 5> stage_ms;
  std::vector<EstimateSample> estimates;
  std::vector<ReportedEnd> reported;  ///< every fresh end of every cycle, primary or other
  std::map<std::string, size_t> reasons;
  std::ofstream cycles_csv;
  rosbag::Bag* poses_bag = nullptr;  ///< --poses-bag
  std::string world_frame;
  /// Drift watch: per camera, times it was flagged (a clear one turning flagged) and cycles it
  /// spent flagged; its last flag state.
  std::map<std::string, size_t> drift_flags, drift_cycles;
  std::map<std::string, bool> drift_state;
  /// Per camera, the largest |shift along the ray| [m] and rotation [deg] it reached.
  std::map<std::string, std::pair<double, double>> drift_max;
  /// Per end: the types its valid cycles published (TypeTally: `reports` counts those cycles);
  /// the last measured tool-joint OD and tube OD [m] and their numbers of measurements.
  struct Types : TypeTally {
    double od = 0.0, od_spread = 0.0, tube_od = 0.0;
    size_t tube_measurements = 0;
    size_t measurements = 0;
  };
  std::array<Types, kNumEnds> types;
};

void tally(const CycleOutput& out, double ms, Tally* t) {
  t->times_ms.push_back(ms);
  const CycleTiming& tm = out.result.timing;
  t->stage_ms[0].push_back(tm.cutout_ms);
  t->stage_ms[1].push_back(tm.fusion_ms);
  t->stage_ms[2].push_back(tm.segmentation_ms);
  t->stage_ms[3].push_back(tm.registration_ms);
  t->stage_ms[4].push_back(tm.edges_ms);
  for (const InputProblem& p : out.problems)
    if (t->problems++ < 5)
      std::cerr << "bench_estimator: a frame of " << p.camera << " left out: " << p.message << "\n";
  for (const CameraDriftStatus& d : out.result.drift) {
    if (d.flagged && !t->drift_state[d.camera]) {
      ++t->drift_flags[d.camera];
      std::cerr << "bench_estimator: drift watch flags " << d.camera << " at stamp "
                << out.cycle.stamp_ns * 1e-9 << " s: " << describeDrift(d) << "\n";
    }
    if (d.flagged) ++t->drift_cycles[d.camera];
    t->drift_state[d.camera] = d.flagged;
    auto& mx = t->drift_max[d.camera];
    mx.first = std::max(mx.first, std::abs(d.ray_shift));
    mx.second = std::max(mx.second, d.rotation);
  }
  for (int e = 0; e < kNumEnds; ++e) {
    const EndEstimate& est = out.result.ends[e];
    if (!est.valid || est.type.empty()) continue;
    Tally::Types& ty = t->types[e];
    ty.add(est.type, est.type_names, est.type_probabilities);
    if (est.type_measurements > 0) {
      ty.od = est.measured_od;
      ty.od_spread = est.measured_od_spread;
      ty.measurements = est.type_measurements;
    }
    if (est.tube_measurements > 0) {
      ty.tube_od = est.measured_tube_od;
      ty.tube_measurements = est.tube_measurements;
    }
  }
  if (t->poses_bag)
    t->poses_bag->write(std::string("/drill_pipe_pose/") + conventions::kPipeEndsTopic,
                        fromNs(out.cycle.stamp_ns), toPipeEndsMsg(out, t->world_frame));
  const auto reportOf = [&](const EndEstimate& e) {
    return ReportedEnd{out.cycle.stamp_ns,        e.label,      e.instance_id,
                       e.T_world_end.translation(), e.type,       e.type_names,
                       e.type_probabilities};
  };
  for (const EndEstimate& e : out.result.ends)
    if (e.valid) t->reported.push_back(reportOf(e));
  for (const EndEstimate& e : out.result.others) t->reported.push_back(reportOf(e));
  std::string cams;
  for (const auto& c : out.result.cameras_used) cams += (cams.empty() ? "" : "+") + c;
  for (int e = 0; e < kNumEnds; ++e) {
    const PublishedEnd& p = out.ends[e];
    EstimateSample s;
    s.stamp_ns = out.cycle.stamp_ns;
    s.label = static_cast<EndLabel>(e);
    s.valid = p.valid;
    s.fresh = p.fresh;
    s.T_world_end = p.estimate.T_world_end;
    s.covariance = p.estimate.covariance;
    t->estimates.push_back(s);
    if (!p.valid)
      ++t->reasons[std::string(labelName(s.label)) + ": " + reasonPattern(p.message)];
    if (t->cycles_csv.is_open()) {
      const Eigen::Vector3d o = p.estimate.T_world_end.translation();
      const Eigen::Quaterniond q(p.estimate.T_world_end.linear());
      t->cycles_csv << s.stamp_ns << "," << cams << "," << labelName(s.label) << ","
                    << (p.valid ? 1 : 0) << "," << (p.fresh ? 1 : 0) << "," << o.x() << ","
                    << o.y() << "," << o.z() << "," << q.x() << "," << q.y() << "," << q.z()
                    << "," << q.w() << "," << p.estimate.type << ",";
      // Each candidate's published probability, name:p joined by ';'.
      const EndEstimate& pe = p.estimate;
      double p_type = 0.0;
      for (size_t k = 0; k < pe.type_names.size() && k < pe.type_probabilities.size(); ++k) {
        if (pe.type_names[k] == pe.type) p_type = pe.type_probabilities[k];
        t->cycles_csv << (k ? ";" : "") << pe.type_names[k] << ":" << pe.type_probabilities[k];
      }
      t->cycles_csv << "," << p_type << "," << 1e3 * pe.measured_od << ","
                    << pe.type_measurements << "," << 1e3 * pe.searched_od << ","
                    << pe.searches_counted << "," << pe.searches << ","
                    << 1e3 * pe.last_search_od << "\n";
    }
  }
  ++t->cycles;
}

/// Every end at once (several pipes): the true ends reported, the ids kept, and the reports
/// off their end (evaluateInstances), the types published on each; INSTANCES and ENDTYPE lines
/// for scripts.
void reportInstances(const BenchOptions& o, const InstanceEvaluation& ev) {
  const auto share = [](size_t a, size_t b) { return b ? static_cast<double>(a) / b : 0.0; };
  std::cout << std::setprecision(4) << "every end: " << ev.true_ends << " true ends, reported in "
            << 100 * share(ev.reported, ev.end_cycles) << " % of end-cycles; id kept in "
            << 100 * share(ev.id_kept, ev.id_pairs) << " % of consecutive pairs; "
            << ev.mixed_ids << " ids on more than one end; " << ev.stray
            << " reports off every end of their label; " << ev.near_other
            << " within 0.2 m of another end\n";
  std::cout << "every end, reported per true end (label #index):";
  for (const auto& [end, n] : ev.per_end)
    std::cout << " " << labelName(static_cast<EndLabel>(end.first)) << " #" << end.second << " "
              << 100 * share(n.second, n.first) << " %";
  std::cout << "\n";
  for (const ReportedEnd& r : ev.near_examples)
    std::cout << "every end, near another end: " << labelName(r.label) << " #" << r.id << " at ("
              << r.origin.x() << ", " << r.origin.y() << ", " << r.origin.z() << ") stamp "
              << r.stamp_ns * 1e-9 << " s\n";
  for (const auto& [r, d] : ev.stray_examples)
    std::cout << "every end, off its label's ends: " << labelName(r.label) << " #" << r.id
              << " at (" << r.origin.x() << ", " << r.origin.y() << ", " << r.origin.z()
              << ") stamp " << r.stamp_ns * 1e-9 << " s, " << d << " m from the nearest\n";
  if (ev.mixed_ids > 0) {
    std::cout << "every end, ids on more than one end:";
    for (const auto& [id, ends] : ev.id_truth)
      if (ends.size() > 1) {
        std::cout << " #" << id << " ->";
        for (const auto& [l, j] : ends)
          std::cout << " " << labelName(static_cast<EndLabel>(l)) << " #" << j;
      }
    std::cout << "\n";
  }
  // Per true end, the types its reports published (one ENDTYPE line per end and type).
  for (const auto& [end, ty] : ev.types) {
    if (ty.reports == 0) continue;
    std::cout << "every end, types on " << labelName(static_cast<EndLabel>(end.first)) << " #"
              << end.second << " at (" << ty.position.x() << ", " << ty.position.y() << ", "
              << ty.position.z() << "):";
    for (const auto& [name, n] : ty.top)
      std::cout << " " << name << " " << 100 * share(n, ty.reports) << " %";
    std::cout << "\n";
    for (const auto& [name, sum] : ty.probability) {
      const auto top = ty.top.find(name);
      const auto least = ty.least_not_top.find(name);
      std::cout << "ENDTYPE label=" << (o.label.empty() ? o.bag_path : o.label)
                << " end=" << labelName(static_cast<EndLabel>(end.first)) << " index=" << end.second
                << " x=" << ty.position.x() << " y=" << ty.position.y()
                << " z=" << ty.position.z() << " type=" << name << " reports=" << ty.reports
                << " top_share=" << share(top == ty.top.end() ? 0 : top->second, ty.reports)
                << " mean_probability=" << sum / static_cast<double>(ty.reports)
                << " confident_share="
                << share(ty.confident.count(name) ? ty.confident.at(name) : 0, ty.reports)
                << " least_probability_not_top="
                << (least == ty.least_not_top.end() ? 1.0 : least->second) << "\n";
    }
  }
  std::cout << "INSTANCES label=" << (o.label.empty() ? o.bag_path : o.label)
            << " true_ends=" << ev.true_ends << " reported=" << share(ev.reported, ev.end_cycles)
            << " id_kept=" << share(ev.id_kept, ev.id_pairs) << " id_pairs=" << ev.id_pairs
            << " mixed_ids=" << ev.mixed_ids << " stray=" << ev.stray
            << " near_other=" << ev.near_other << "\n";
}

void report(const BenchOptions& o, const std::string& method, size_t n_cameras, const Tally& t,
            const std::array<EndEvaluation, kNumEnds>& evals,
            const std::vector<TrueJoint>& joints) {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  const std::string label = o.label.empty() ? o.bag_path : o.label;
  std::cout << std::fixed << std::setprecision(2);
  std::cout << "== " << label << " | method " << method << " | " << n_cameras << " cameras | "
            << t.cycles << " cycles\n";
  std::cout << "time per cycle [ms]: median " << percentile(t.times_ms, 0.5) << ", p95 "
            << percentile(t.times_ms, 0.95) << ", p99 " << percentile(t.times_ms, 0.99)
            << ", max " << percentile(t.times_ms, 1.0) << " | peak RSS " << ru.ru_maxrss / 1024.0
            << " MB\n";
  std::cout << "stage medians [ms]: cut-out " << percentile(t.stage_ms[0], 0.5) << ", fusion "
            << percentile(t.stage_ms[1], 0.5) << ", segmentation "
            << percentile(t.stage_ms[2], 0.5) << ", registration "
            << percentile(t.stage_ms[3], 0.5) << " (of which the edge scans "
            << percentile(t.stage_ms[4], 0.5) << ")\n";
  printEvaluation(evals, std::cout);
  for (const auto& [why, n] : t.reasons) std::cout << "invalid " << n << "x: " << why << "\n";
  size_t flags = 0, flagged_cycles = 0;
  std::string flagged_cams;
  for (const auto& [cam, n] : t.drift_flags) {
    flags += n;
    flagged_cams += " " + cam + " " + std::to_string(n) + "x (" +
                    std::to_string(t.drift_cycles.at(cam)) + " cycles)";
  }
  for (const auto& [cam, n] : t.drift_cycles) flagged_cycles += n;
  std::cout << "drift flags: " << flags << (flags ? ":" + flagged_cams : "") << "\n";
  std::cout << "drift largest |shift along the ray| [mm] / rotation [deg]:";
  for (const auto& [cam, mx] : t.drift_max)
    std::cout << " " << cam << " " << std::fixed << std::setprecision(1) << mx.first * 1e3 << " / "
              << std::setprecision(2) << mx.second;
  std::cout << "\n";
  std::cout << "DRIFT label=" << label << " method=" << method << " flags=" << flags
            << " flagged_cycles=" << flagged_cycles << "\n";
  // Pipe types: per end, the published types' shares of its valid cycles and the mean probability
  // of each candidate (one machine-readable TYPE line per end and type).
  for (int e = 0; e < kNumEnds; ++e) {
    const Tally::Types& ty = t.types[e];
    if (!ty.reports) continue;
    // The joint's OD as rendered, where the bag names one joint of this label (one pipe).
    std::ostringstream od_error;
    std::vector<double> rendered;
    for (const TrueJoint& j : joints)
      if (static_cast<int>(j.label) == e) rendered.push_back(j.rendered_od);
    const bool judged = rendered.size() == 1 && ty.measurements > 0;
    if (judged)
      od_error << std::fixed << std::setprecision(4) << " true_od_mm=" << rendered[0] * 1e3
               << " od_error_mm=" << (ty.od - rendered[0]) * 1e3;
    std::cout << std::fixed << "pipe type " << labelName(static_cast<EndLabel>(e)) << ": measured OD "
              << std::setprecision(1) << ty.od * 1e3 << " mm (spread " << ty.od_spread * 1e3
              << " mm, " << ty.measurements << " measurements), tube OD " << ty.tube_od * 1e3
              << " mm (" << ty.tube_measurements << " measurements);";
    if (judged)
      std::cout << " joint as rendered " << std::setprecision(1) << rendered[0] * 1e3 << " mm;";
    for (const auto& [name, n] : ty.top)
      std::cout << " " << name << " " << std::setprecision(1) << 100.0 * n / ty.reports << " %";
    std::cout << "\n";
    for (const auto& [name, sum] : ty.probability) {
      const auto it = ty.top.find(name);
      std::cout << "TYPE label=" << label << " end=" << labelName(static_cast<EndLabel>(e))
                << " type=" << name << std::setprecision(4)
                << " top_share=" << (it == ty.top.end() ? 0.0 : 1.0 * it->second / ty.reports)
                << " mean_probability=" << sum / ty.reports;
      const auto sure = ty.confident.find(name);
      std::cout << " confident_share="
                << (sure == ty.confident.end() ? 0.0 : 1.0 * sure->second / ty.reports);
      // 1 where the type was published in every valid cycle.
      const auto least = ty.least_not_top.find(name);
      std::cout << " least_probability_not_top="
                << (least == ty.least_not_top.end() ? 1.0 : least->second)
                << " measured_od_mm=" << ty.od * 1e3 << od_error.str() << "\n";
    }
  }
  // One machine-readable line per end for scripts/bench.
  for (const auto& ev : evals) {
    if (!ev.present) continue;
    const auto& s = ev.stats;
    std::cout << "RESULT label=" << label << " method=" << method
              << " end=" << labelName(ev.label) << " cycles=" << t.cycles
              << " expected=" << s.expected_cycles << " estimates=" << s.estimates
              << std::setprecision(3) << " median_ms=" << percentile(t.times_ms, 0.5)
              << " p95_ms=" << percentile(t.times_ms, 0.95)
              << " p99_ms=" << percentile(t.times_ms, 0.99) << " rss_mb=" << ru.ru_maxrss / 1024.0
              << " mean_err_mm=" << s.mean_position_error * 1e3
              << " std_x_mm=" << s.std_position.x() * 1e3
              << " std_y_mm=" << s.std_position.y() * 1e3
              << " std_z_mm=" << s.std_position.z() * 1e3
              << " mean_axis_deg=" << s.mean_axis_angle * 180 / M_PI
              << " within_1cm_1deg=" << s.fractionWithin(0.01, M_PI / 180)
              << " within_2cm_2deg=" << s.fractionWithin(0.02, 2 * M_PI / 180)
              << " in_3sigma=" << ev.within_3sigma << " axis_in_3sigma=" << ev.axis_within_3sigma
              << " sigma_to_error=" << ev.sigma_to_error
              << " fresh_median_mm=" << ev.fresh_median_error * 1e3
              << " fresh_p95_mm=" << ev.fresh_p95_error * 1e3 << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  const BenchOptions opt = parseArgs(argc, argv);
  try {
    rosbag::Bag bag;
    try {
      bag.open(opt.bag_path, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
      fail("cannot open bag '", opt.bag_path, "': ", e.what());
    }
    BagContents bc;
    readBagContents(bag, opt.skip_camera, &bc);
    if (bc.cameras.empty()) fail("bag '", opt.bag_path, "' has no SensorFrames");
    const EstimatorNodeConfig cfg = makeConfig(opt, bc.cameras);
    CycleRunner runner(cfg, &bc.tf);
    for (const auto& cam : runner.camerasWithoutDepthCorrection())
      std::cerr << "bench_estimator: camera " << cam << " is not in the rig file '" << cfg.rig
                << "': its depth is not corrected\n";
    const std::string types_warning = runner.tallyWarning();
    if (!types_warning.empty()) std::cerr << "bench_estimator: " << types_warning << "\n";
    Tally t;
    if (!opt.cycles_csv_path.empty()) {
      t.cycles_csv.open(opt.cycles_csv_path);
      if (!t.cycles_csv) fail("cannot write '", opt.cycles_csv_path, "'");
      t.cycles_csv << "stamp_ns,cameras,end,valid,fresh,x,y,z,qx,qy,qz,qw,type,probabilities,"
                      "type_probability,measured_od_mm,type_measurements,searched_od_mm,"
                      "searches_counted,searches,last_search_od_mm\n";
      t.cycles_csv.precision(17);
    }
    rosbag::Bag poses_bag;
    if (!opt.poses_bag_path.empty()) {
      try {
        poses_bag.open(opt.poses_bag_path, rosbag::bagmode::Write);
      } catch (const rosbag::BagException& e) {
        fail("cannot write the poses bag '", opt.poses_bag_path, "': ", e.what());
      }
      t.poses_bag = &poses_bag;
      t.world_frame = cfg.world_frame;
    }
    // Every frame arrives 10 ms after its capture; each poll's time is shared by its cycles.
    auto poll = [&](double now) {
      if (opt.max_cycles && t.cycles >= opt.max_cycles) return;
      const auto t0 = std::chrono::steady_clock::now();
      const std::vector<CycleOutput> outs = runner.poll(now);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
              .count();
      for (const CycleOutput& out : outs) tally(out, ms / outs.size(), &t);
    };
    int64_t first_stamp = 0, last_stamp = 0;
    std::set<std::string> amplitude_refused;  // cameras whose amplitude was refused (told once)
    for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
      auto sf = sensorFrameOf(m);
      if (!sf || sf->camera == opt.skip_camera) continue;
      const int64_t stamp = toNs(sf->header.stamp);
      if (!first_stamp) first_stamp = stamp;
      last_stamp = std::max(last_stamp, stamp);
      runner.add(sf->camera, stamp, stamp * 1e-9 + 0.010, [sf, &amplitude_refused] {
        SensorFrameData f = fromMsg(sf);
        if (!f.amplitude_refused.empty() && amplitude_refused.insert(f.camera).second)
          std::cerr << "bench_estimator: " << f.amplitude_refused << " (first of this camera)\n";
        return f;
      });
      poll(stamp * 1e-9 + 0.010);
      if (opt.max_cycles && t.cycles >= opt.max_cycles) break;
    }
    poll(1e18);
    if (t.poses_bag) poses_bag.close();

    EvaluationOptions eo;
    // Expected cycles: 30 per second of input actually processed.
    const int64_t span_ns = opt.max_cycles && t.cycles >= opt.max_cycles && !t.estimates.empty()
                                ? t.estimates.back().stamp_ns - first_stamp
                                : last_stamp - first_stamp;
    eo.expected_cycles = std::max<size_t>(t.cycles, std::llround(span_ns * 1e-9 * 30.0));
    const auto evals = evaluate(bc.truth, t.estimates, eo);
    report(opt, estimatorMethodName(cfg.estimator.method), bc.cameras.size(), t, evals, bc.joints);
    reportInstances(opt, evaluateInstances(bc.true_ends, t.reported));
    if (!opt.csv_path.empty()) {
      std::ofstream f(opt.csv_path);
      if (!f) fail("cannot write '", opt.csv_path, "'");
      writeErrorCsv(evals, f);
    }
  } catch (const InputError& e) {
    std::cerr << "bench_estimator: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
