// evaluate: scores a bag of estimates (PipeEnds) against the simulator's ground truth.
//
//   rosrun drill_pipe_pose evaluate BAG [--ns /drill_pipe_pose] [--csv errors.csv]
//                                       [--rate 30] [--expected N]
//
// Ground truth (/ground_truth/<end>, PoseStamped) is interpolated at each cycle stamp; missing or
// invalid poses count as failures against the expected cycles (rate x ground-truth span, or N).
// Prints the thesis-style table per end, the symmetry-aware errors and success rates, and the
// latency recorded in the status messages (meaningful for a 1x replay).
// Exit status 0; 1 on a bad bag; 2 on a bad command line.
#include <drill_pipe_pose/EstimatorStatus.h>
#include <drill_pipe_pose/PipeEnds.h>
#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_eigen/tf2_eigen.h>

#include <fstream>
#include <iomanip>
#include <iostream>
#include <set>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/evaluation.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "cli.hpp"

using namespace drill_pipe_pose;

int main(int argc, char** argv) {
  std::string bag_path, ns = "/drill_pipe_pose", csv_path;
  EvaluationOptions opt;
  CLI::App app{"Scores a bag of estimates (PipeEnds) against the simulator's ground truth.",
               "evaluate"};
  tools::configureApp(app);
  app.add_option("BAG", bag_path, "bag with the estimator's output and the ground truth")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--ns", ns, "namespace of the estimator's topics (<ns>/pipe_ends, <ns>/status)")
      ->capture_default_str();
  app.add_option("--csv", csv_path, "write one row per scored estimate to this CSV file");
  app.add_option("--rate", opt.expected_rate_hz,
                 "[Hz] expected cycles per second of ground truth (unless --expected)")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 1000.0));
  app.add_option("--expected", opt.expected_cycles,
                 "expected cycles in all (0: --rate x the ground truth's span)")
      ->capture_default_str()
      ->check(CLI::Range(size_t{0}, size_t{1000000000}));
  tools::parseOrExit(app, argc, argv);
  try {
    rosbag::Bag bag;
    try {
      bag.open(bag_path, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
      fail("cannot open bag '", bag_path, "': ", e.what());
    }
    const std::string ends_topic = ns + "/" + conventions::kPipeEndsTopic;
    const std::string status_topic = ns + "/" + conventions::kStatusTopic;
    std::array<GroundTruthTrack, kNumEnds> truth;
    std::vector<EstimateSample> estimates;
    std::vector<double> latency_ms;
    size_t cycles = 0;
    rosbag::View view(bag);
    std::set<std::string> topics;
    for (const rosbag::MessageInstance& m : view) {
      topics.insert(m.getTopic());
      if (m.getTopic() == ends_topic) {
        const auto msg = m.instantiate<PipeEnds>();
        if (!msg) continue;
        ++cycles;
        for (const auto& end : msg->ends) {
          EstimateSample s;
          s.stamp_ns = toNs(msg->header.stamp);
          s.label = parseEndLabel(end.label, ends_topic);
          s.valid = end.valid;
          tf2::fromMsg(end.pose.pose, s.T_world_end);
          for (int r = 0; r < 6; ++r)
            for (int c = 0; c < 6; ++c) s.covariance(r, c) = end.pose.covariance[6 * r + c];
          estimates.push_back(s);
        }
      } else if (m.getTopic() == status_topic) {
        const auto msg = m.instantiate<EstimatorStatus>();
        if (msg && msg->latency_ms > 0) latency_ms.push_back(msg->latency_ms);
      } else {
        for (EndLabel e : {EndLabel::kBoxEnd, EndLabel::kPinEnd})
          if (m.getTopic() == conventions::groundTruthTopic(e)) {
            const auto msg = m.instantiate<geometry_msgs::PoseStamped>();
            if (!msg) continue;
            Eigen::Isometry3d T;
            tf2::fromMsg(msg->pose, T);
            truth[static_cast<int>(e)].add(toNs(msg->header.stamp), T);
          }
      }
    }
    if (truth[0].empty() && truth[1].empty())
      fail("bag '", bag_path,
           "' has no ground truth on /ground_truth/box_end or /ground_truth/pin_end");
    if (cycles == 0) {
      std::string list;
      for (const auto& t : topics) list += " " + t;
      fail("bag '", bag_path, "' has no PipeEnds on ", ends_topic, " (topics:", list, ")");
    }
    std::cout << "bag " << bag_path << ": " << cycles << " estimator cycles\n";
    const auto evals = evaluate(truth, estimates, opt);
    printEvaluation(evals, std::cout);
    if (!latency_ms.empty())
      std::cout << std::fixed << std::setprecision(1)
                << "latency [ms] (publish - arrival of the cycle's last frame, "
                << latency_ms.size() << " cycles): median " << percentile(latency_ms, 0.5)
                << ", p95 " << percentile(latency_ms, 0.95) << ", p99 "
                << percentile(latency_ms, 0.99) << "\n";
    if (!csv_path.empty()) {
      std::ofstream f(csv_path);
      if (!f) fail("cannot write CSV '", csv_path, "'");
      writeErrorCsv(evals, f);
      std::cout << "wrote " << csv_path << "\n";
    }
  } catch (const InputError& e) {
    std::cerr << "evaluate: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
