// pose_estimator: the central node. N cameras' SensorFrames -> per-end poses.
//
// Thin by design: parameters into structs, messages and TF into core types; the ROS-free
// CycleRunner does the work (as in bench_estimator); results out as messages (README "Topics").
#include <diagnostic_msgs/DiagnosticArray.h>
#include <drill_pipe_pose/EstimatorStatus.h>
#include <drill_pipe_pose/PipeEndArray.h>
#include <drill_pipe_pose/PipeEnds.h>
#include <drill_pipe_pose/SensorFrame.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <topic_tools/shape_shifter.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <filesystem>
#include <array>
#include <cstdio>
#include <map>

#include "drill_pipe_pose/core/cycle_runner.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/ros/estimator_params.hpp"
#include "drill_pipe_pose/ros/tf_source.hpp"

namespace drill_pipe_pose {
namespace {

double wallNow() {
  return ros::WallTime::now().toSec();
}

using NodeConfig = EstimatorNodeConfig;  // core/estimator/estimator_params_table.hpp

class PoseEstimatorNode {
 public:
  PoseEstimatorNode(ros::NodeHandle nh, ros::NodeHandle pnh)
      : nh_(nh),
        pnh_(pnh),
        cfg_(loadEstimatorNodeConfig(pnh)),
        tf_listener_(tf_buffer_),
        tf_(&tf_buffer_, cfg_.tf_timeout),
        runner_(cfg_, &tf_) {
    static_tf_sub_ = nh_.subscribe("/tf_static", 100, &PoseEstimatorNode::onStaticTf, this);
    for (const auto& cam : cfg_.cameras) {
      subs_[cam] = subscribe(cam);
      counters_[cam];
    }
    for (int e = 0; e < kNumEnds; ++e)
      pose_pubs_[e] = pnh_.advertise<geometry_msgs::PoseWithCovarianceStamped>(
          conventions::poseTopic(static_cast<EndLabel>(e)), 10);
    ends_pub_ = pnh_.advertise<PipeEnds>(conventions::kPipeEndsTopic, 10);
    types_pub_ = pnh_.advertise<PipeEndArray>(conventions::kPipeEndTypesTopic, 10);
    status_pub_ = pnh_.advertise<EstimatorStatus>(conventions::kStatusTopic, 10);
    diag_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
    fused_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("debug/fused", 1);
    segmented_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("debug/segmented", 1);
    marker_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("debug/models", 1);
    poll_timer_ = nh_.createWallTimer(ros::WallDuration(0.005), [this](const ros::WallTimerEvent&) {
      processReady();
      const double now = wallNow();
      const auto& stats = runner_.sync().stats();  // no allocation on this 5 ms tick
      bool none_live = true;
      for (const auto& kv : stats) none_live = none_live && !kv.second.live;
      if (none_live) last_none_live_ = now;
      for (const auto& cam : cfg_.cameras)
        resubscribeIfSilent(cam, stats.at(cam), now, none_live, &counters_[cam]);
    });
    diag_timer_ = nh_.createWallTimer(ros::WallDuration(1.0),
                                      [this](const ros::WallTimerEvent&) { publishDiagnostics(); });
    std::string cams;
    for (const auto& c : cfg_.cameras) cams += " " + c;
    ROS_INFO(
        "pose_estimator: fusing %zu camera(s):%s; world frame '%s'; sync window %.1f ms, "
        "max wait %.1f ms, camera timeout %.2f s; max pose age %.2f s",
        cfg_.cameras.size(), cams.c_str(), cfg_.world_frame.c_str(),
        cfg_.sync.window * 1e3, cfg_.sync.max_wait * 1e3,
        cfg_.sync.camera_timeout, cfg_.max_pose_age);
    ROS_INFO("pose_estimator: %s", describeEstimatorConfig(cfg_.estimator).c_str());
    const std::string tally = runner_.tallyWarning();
    if (!tally.empty()) ROS_WARN("pose_estimator: %s", tally.c_str());
    logDepthCorrections();
  }

 private:
  /// Once at start: each camera's depth correction from the rig file, and the cameras it lacks.
  void logDepthCorrections() const {
    if (cfg_.rig.empty()) return;
    std::string list;
    char buf[128];
    for (const auto& [cam, c] : runner_.depthCorrections()) {
      std::snprintf(buf, sizeof buf, " %s %+.1f mm x %.4f", cam.c_str(), c.offset * 1e3, c.scale);
      list += buf;
      if (c.weak_return_bias >= 0.0) {  // its own weak-return law (calibrate_rig)
        std::snprintf(buf, sizeof buf, " (weak-return B %.4g)", c.weak_return_bias);
        list += buf;
      }
    }
    ROS_INFO("pose_estimator: depth corrections from rig file '%s':%s", cfg_.rig.c_str(),
             list.empty() ? " none" : list.c_str());
    for (const auto& cam : runner_.camerasWithoutDepthCorrection())
      ROS_WARN("pose_estimator: camera '%s' is not in the rig file '%s': depth not corrected",
               cam.c_str(), cfg_.rig.c_str());
  }

  struct Counters {
    uint64_t bad_input = 0, tf_failures = 0, received_at_last_diag = 0;
    double last_resubscribe = 0;  ///< [s] wall clock of the last re-subscription
    /// The counts at the last /diagnostics tick, and the wall clock [s] of the last tick at which
    /// each problem was seen: a camera's WARN says what went wrong lately, and clears.
    uint64_t bad_at_diag = 0, tf_at_diag = 0, stale_at_diag = 0;
    double bad_seen = -1e9, tf_seen = -1e9, late_seen = -1e9;
    std::string late_text;  ///< the last tick's late frames, "N of M"
  };

  /// Any message type is accepted on the topic and told apart by its MD5 sum (sensorFrameOf):
  /// the current SensorFrame, or the definition before its amplitude field (a bag recorded
  /// before it, a sensor node not yet updated), which plays on without amplitude.
  ros::Subscriber subscribe(const std::string& cam) {
    const std::string topic = conventions::sensorFrameTopic(cam);
    return nh_.subscribe<topic_tools::ShapeShifter>(
        topic, 10,
        [this, cam, topic](const topic_tools::ShapeShifter::ConstPtr& m) {
          if (SensorFrameConstPtr sf = sensorFrameOf(*m)) return onFrame(cam, sf);
          ROS_ERROR_THROTTLE(10.0,
                             "pose_estimator: %s: %s carries %s (MD5 %s), not a "
                             "drill_pipe_pose/SensorFrame of this or the previous definition: "
                             "frames ignored (every 10 s at most)",
                             cam.c_str(), topic.c_str(), m->getDataType().c_str(),
                             m->getMD5Sum().c_str());
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  /// A camera that sent frames and has gone silent for sync/camera_timeout is subscribed to
  /// afresh, every kResubscribeEvery s while it stays silent (the old subscription shut down): a sensor node restarted on its old
  /// XML-RPC port (the kernel may hand it back) keeps its URI, and roscpp, seeing the same
  /// publisher, never connects to the new process (a restarted cam5 stayed silent for good in the
  /// fault-injection rostest).
  /// While no camera is live (a stopped bag, the sensor network down) a restart is not the likely
  /// cause: only every kResubscribeAllSilent s, and none in the first kStartGrace s after a camera
  /// came back. A new subscription drops the frames that arrive while it connects: with all six
  /// resubscribed every second, a bag that started at that moment lost cam1's and cam4's first
  /// frames (estimator_replay.test, test_5, on a clean 2-core CI run), and the log had six lines
  /// a second while nothing played.
  void resubscribeIfSilent(const std::string& cam, const CameraSyncStats& st, double now,
                           bool none_live, Counters* cnt) {
    constexpr double kResubscribeEvery = 1.0;  // [s] cheap: one master call
    constexpr double kResubscribeAllSilent = 10.0, kStartGrace = 1.0;  // [s]
    const double every = none_live ? kResubscribeAllSilent : kResubscribeEvery;
    if (st.received == 0 || st.live || now - cnt->last_resubscribe < every) return;
    if (!none_live && now - last_none_live_ < kStartGrace) return;
    cnt->last_resubscribe = now;
    ROS_INFO("pose_estimator: %s silent for %.1f s: subscribing to %s afresh (a restarted sensor "
             "node)", cam.c_str(), now - st.last_arrival,
             conventions::sensorFrameTopic(cam).c_str());
    subs_[cam].shutdown();  // first: a second Subscriber would share the stale subscription
    subs_[cam] = subscribe(cam);
  }

  void onFrame(const std::string& cam, const SensorFrameConstPtr& msg) {
    const int64_t stamp = toNs(msg->header.stamp);
    const AddResult r = runner_.add(cam, stamp, wallNow(), [msg, this] {
      SensorFrameData f = fromMsg(msg, cfg_.limits);
      if (!f.amplitude_refused.empty())
        ROS_WARN_THROTTLE(10.0, "pose_estimator: %s (every 10 s at most)",
                          f.amplitude_refused.c_str());
      return f;
    });
    if (r.time_jumped_back) {
      ROS_WARN(
          "pose_estimator: %s frame stamped %.3f s is %.1f s older than the last cycle: "
          "time jumped back (looped bag?); buffers and poses were reset",
          cam.c_str(), stamp * 1e-9, r.jump_s);
      ++clock_.jumps_back;
      clock_.last_jump_s = r.jump_s;
      clock_.last_jump_wall = wallNow();
    }
    if (!r.accepted)
      ROS_DEBUG("pose_estimator: %s frame %.3f s too late for its cycle", cam.c_str(),
                stamp * 1e-9);
    processReady();
  }

  void processReady() {
    for (const CycleOutput& out : runner_.poll(wallNow())) {
      report(out);
      publish(out);
    }
  }

  /// Logs (throttled) and counts the frames a cycle left out and the cameras it skipped.
  void report(const CycleOutput& out) {
    for (const InputProblem& p : out.problems) {
      if (p.kind == InputProblem::Kind::kTransform) {
        ++counters_[p.camera].tf_failures;
        if (throttle("tf " + p.camera, 5.0))
          ROS_WARN("pose_estimator: no transform for %s (throttled, 5 s): %s", p.camera.c_str(),
                   p.message.c_str());
      } else {
        ++counters_[p.camera].bad_input;
        if (throttle("bad input " + p.camera, 5.0))
          ROS_ERROR("pose_estimator: dropping a frame of %s (throttled, 5 s): %s",
                    p.camera.c_str(), p.message.c_str());
      }
    }
    for (const auto& err : out.result.camera_errors)
      if (throttle(err.substr(0, err.find(':')), 5.0))
        ROS_ERROR("pose_estimator: %s (throttled, 5 s)", err.c_str());
  }

  void publish(const CycleOutput& out) {
    const CycleResult& r = out.result;
    const ros::Time stamp = fromNs(out.cycle.stamp_ns);
    PipeEnds ends = toPipeEndsMsg(out, cfg_.world_frame);
    PipeEndArray typed;
    typed.header = ends.header;
    EstimatorStatus status;
    status.header = ends.header;
    status.cameras_configured = cfg_.cameras;
    status.cameras_live = runner_.sync().liveCameras();
    status.cameras_used = r.cameras_used;
    for (const CameraDriftStatus& d : r.drift) {
      if (d.flagged) status.cameras_drifted.push_back(d.camera);
      if (d.flagged && !drift_[d.camera].flagged)
        ROS_WARN("pose_estimator: camera %s disagrees with the fused fit (%s): moved since its "
                 "calibration? %s", d.camera.c_str(), describeDrift(d).c_str(),
                 cfg_.estimator.drift.leave_out ? "left out of the fit until it agrees"
                                                : "still in the fit");
      if (!d.flagged && drift_[d.camera].flagged)
        ROS_INFO("pose_estimator: camera %s agrees with the fused fit again (%s)",
                 d.camera.c_str(), describeDrift(d).c_str());
      drift_[d.camera] = d;
    }
    std::string message;
    for (int e = 0; e < kNumEnds; ++e) {
      const EndEstimate& est = r.ends[e];
      const PublishedEnd& pub = out.ends[e];
      if (est.valid) publishPose(e, est, stamp);
      const PipeEnd& end = ends.ends[e];
      if (!end.message.empty()) message += std::string(end.label) + ": " + end.message + ". ";
      status.ends.push_back(end.label);
      status.points.push_back(est.points);
      status.residual.push_back(est.residual);
      status.instances.push_back(r.instances[e]);
      typed.ends.push_back(typedEnd(end, pub.valid ? &pub.estimate : nullptr));
      // The primary pair's type on the status too: a machine reading <end>/pose sees there
      // whether the type (and so the model the pose was fitted with) is in doubt.
      const TypedPipeEnd& t = typed.ends.back();
      double top = 0.0;
      for (size_t k = 0; k < t.candidates.size() && k < t.probabilities.size(); ++k)
        if (t.candidates[k] == t.type) top = t.probabilities[k];
      status.types.push_back(t.type);
      status.type_probability.push_back(top);
      status.type_ambiguous.push_back(!t.type.empty() && t.ambiguous);
      if (end.valid && !t.type.empty() && t.ambiguous)
        message += std::string(end.label) + ": type ambiguous (" + describeTypes(t) +
                   "), posed with " + t.type + "'s model. ";
    }
    // Every other end in the work zone (several pipes at once): pipe_end_types only.
    for (const EndEstimate& est : r.others) {
      PipeEnd end;
      end.label = labelName(est.label);
      end.valid = true;
      fillPipeEnd(est, &end);
      typed.ends.push_back(typedEnd(end, &est));
    }
    status.cutout_ms = r.timing.cutout_ms;
    status.fusion_ms = r.timing.fusion_ms;
    status.segmentation_ms = r.timing.segmentation_ms;
    status.registration_ms = r.timing.registration_ms;
    status.total_ms = r.timing.total_ms;
    status.message = message;
    ends_pub_.publish(ends);
    types_pub_.publish(typed);
    status.latency_ms = (wallNow() - out.cycle.last_arrival) * 1e3;
    status_pub_.publish(status);
    publishDebug(r, stamp, out.inputs);
  }

  /// "5in_NC50_6.625od 0.55, 4.5in_NC50_6.625od 0.45": the candidates above 0.05, most likely
  /// first.
  static std::string describeTypes(const TypedPipeEnd& t) {
    std::vector<std::pair<double, std::string>> c;
    for (size_t k = 0; k < t.candidates.size() && k < t.probabilities.size(); ++k)
      if (t.probabilities[k] >= 0.05) c.emplace_back(t.probabilities[k], t.candidates[k]);
    std::sort(c.rbegin(), c.rend());
    std::string s;
    char buf[32];
    for (const auto& [p, name] : c) {
      std::snprintf(buf, sizeof buf, " %.2f", p);
      s += (s.empty() ? "" : ", ") + name + buf;
    }
    return s;
  }

  /// The end with its instance id and pipe type (of the estimate it publishes; null: none).
  TypedPipeEnd typedEnd(const PipeEnd& end, const EndEstimate* est) const {
    TypedPipeEnd t;
    t.end = end;
    if (!est) return t;
    const EndEstimate& e = *est;
    t.id = e.instance_id;
    t.type = e.type;
    t.candidates = e.type_names;
    t.probabilities = e.type_probabilities;
    double top = 0;
    for (double p : e.type_probabilities) top = std::max(top, p);
    t.ambiguous = top < cfg_.estimator.typing.switch_probability;
    t.measured_od = e.measured_od;
    t.measured_od_spread = e.measured_od_spread;
    t.od_measurements = static_cast<uint32_t>(e.type_measurements);
    t.measured_tube_od = e.measured_tube_od;
    t.tube_measurements = static_cast<uint32_t>(e.tube_measurements);
    return t;
  }

  void publishPose(int e, const EndEstimate& est, const ros::Time& stamp) {
    geometry_msgs::PoseWithCovarianceStamped p;
    p.header.stamp = stamp;
    p.header.frame_id = cfg_.world_frame;
    p.pose.pose = tf2::toMsg(est.T_world_end);
    for (int i = 0; i < 36; ++i) p.pose.covariance[i] = est.covariance(i / 6, i % 6);
    pose_pubs_[e].publish(p);
    tf_broadcaster_.sendTransform(
        toTransformMsg(est.T_world_end, cfg_.world_frame, cfg_.end_frames[e], stamp));
  }

  sensor_msgs::PointCloud2 cloudMsg(
      const std::vector<std::pair<const std::vector<Eigen::Vector3f>*, uint32_t>>& parts,
      const ros::Time& stamp) {
    sensor_msgs::PointCloud2 c;
    c.header.stamp = stamp;
    c.header.frame_id = cfg_.world_frame;
    sensor_msgs::PointCloud2Modifier mod(c);
    mod.setPointCloud2FieldsByString(2, "xyz", "rgb");
    size_t n = 0;
    for (const auto& p : parts) n += p.first->size();
    mod.resize(n);
    sensor_msgs::PointCloud2Iterator<float> x(c, "x"), y(c, "y"), z(c, "z");
    sensor_msgs::PointCloud2Iterator<uint8_t> rgb(c, "rgb");
    for (const auto& [pts, colour] : parts)
      for (const auto& p : *pts) {
        *x = p.x(), *y = p.y(), *z = p.z();
        rgb[0] = colour & 0xff, rgb[1] = (colour >> 8) & 0xff, rgb[2] = (colour >> 16) & 0xff;
        ++x, ++y, ++z, ++rgb;
      }
    return c;
  }

  /// The end's axis (z: the direction a pose means for a pipe end) as an arrow from its origin,
  /// and its instance id, type and the type's probability as a label at the arrow's tip; both
  /// like the end's mesh marker `m` (frame, stamp, colour), deleted with it.
  static std::array<visualization_msgs::Marker, 2> axisAndLabel(
      const visualization_msgs::Marker& m, const EndEstimate& est) {
    visualization_msgs::Marker arrow = m, label = m;
    arrow.ns = m.ns + " axis";
    arrow.type = visualization_msgs::Marker::ARROW;
    arrow.mesh_resource.clear();
    arrow.pose = geometry_msgs::Pose();
    arrow.pose.orientation.w = 1.0;
    arrow.scale.x = 0.02;  // shaft diameter [m]
    arrow.scale.y = 0.04;  // head diameter
    arrow.scale.z = 0.06;  // head length
    label.ns = m.ns + " type";
    label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    label.mesh_resource.clear();
    label.scale.x = label.scale.y = label.scale.z = 0.07;
    label.color.r = label.color.g = label.color.b = label.color.a = 1.0f;
    if (!est.valid) return {arrow, label};
    const Eigen::Vector3d o = est.T_world_end.translation();
    const Eigen::Vector3d tip = o + 0.4 * est.T_world_end.linear().col(2);
    geometry_msgs::Point a, b;
    a.x = o.x(), a.y = o.y(), a.z = o.z();
    b.x = tip.x(), b.y = tip.y(), b.z = tip.z();
    arrow.points = {a, b};
    double top = 0;
    for (double p : est.type_probabilities) top = std::max(top, p);
    char text[200];
    std::snprintf(text, sizeof text, "%s #%u\n%s %.2f", m.ns.c_str(), est.instance_id,
                  est.type.c_str(), top);
    label.text = text;
    label.pose = geometry_msgs::Pose();
    label.pose.position = b;
    label.pose.orientation.w = 1.0;
    return {arrow, label};
  }

  /// The other ends (several pipes at once), each under its instance id, grey; they fade out a
  /// few cycles after their last fit (lifetime) instead of being deleted.
  void otherEndMarkers(const CycleResult& r, const ros::Time& stamp,
                       visualization_msgs::MarkerArray* ma) {
    for (const EndEstimate& est : r.others) {
      visualization_msgs::Marker m;
      m.header.stamp = stamp;
      m.header.frame_id = cfg_.world_frame;
      m.ns = std::string(labelName(est.label)) + " other";
      m.id = static_cast<int>(est.instance_id);
      m.type = visualization_msgs::Marker::MESH_RESOURCE;
      m.mesh_resource =
          std::string("package://drill_pipe_pose/models/") + labelName(est.label) + ".stl";
      m.scale.x = m.scale.y = m.scale.z = 1.0;
      m.color.a = 0.5f;
      m.color.r = m.color.g = m.color.b = 0.7f;
      m.action = visualization_msgs::Marker::ADD;
      m.pose = tf2::toMsg(est.T_world_end);
      setTypeMesh(est, &m);
      m.lifetime = ros::Duration(0.3);
      ma->markers.push_back(m);
      for (auto& extra : axisAndLabel(m, est)) ma->markers.push_back(std::move(extra));
    }
  }

  /// The end's marker as its published type's model: the type's profile revolved, written once
  /// per type and label as an STL file under $ROS_HOME/drill_pipe_pose_models/ (file:// mesh
  /// resource, lit as the package's own meshes); the 5" NC50 mesh file (models/<label>.stl) when
  /// the end has no type, the type is not a candidate or the file cannot be written.
  void setTypeMesh(const EndEstimate& est, visualization_msgs::Marker* m) {
    const std::vector<PipeCandidate>& candidates = runner_.candidates();
    const auto c = std::find_if(candidates.begin(), candidates.end(),
                                [&](const PipeCandidate& p) { return p.name == est.type; });
    if (est.type.empty() || c == candidates.end()) return;
    const std::string key = est.type + "_" + labelName(est.label);
    auto it = type_meshes_.find(key);
    if (it == type_meshes_.end()) {
      const char* home = std::getenv("ROS_HOME");
      const char* user = std::getenv("HOME");
      const std::string dir = std::string(home ? home : (user ? std::string(user) + "/.ros" : "/tmp")) +
                              "/drill_pipe_pose_models";
      const std::string path = dir + "/" + key + ".stl";
      std::string url;
      try {
        std::filesystem::create_directories(dir);
        writeStl(revolveProfile(toolJointProfile(est.label, c->dims)), path);
        url = "file://" + path;
      } catch (const std::exception& e) {
        ROS_WARN("pose_estimator: the model of %s for rviz cannot be written (%s): the 5\" NC50 "
                 "mesh is shown for it", key.c_str(), e.what());
      }
      it = type_meshes_.emplace(key, url).first;
    }
    if (!it->second.empty()) m->mesh_resource = it->second;
  }

  void publishDebug(const CycleResult& r, const ros::Time& stamp,
                    const std::vector<CameraInput>& inputs) {
    if (fused_pub_.getNumSubscribers() > 0)
      fused_pub_.publish(cloudMsg({{&r.fused, 0xc0c0c0}}, stamp));
    if (segmented_pub_.getNumSubscribers() > 0)
      segmented_pub_.publish(
          cloudMsg({{&r.segmented[0], 0x20a0ff}, {&r.segmented[1], 0xff6020}}, stamp));
    if (marker_pub_.getNumSubscribers() == 0) return;
    visualization_msgs::MarkerArray ma;
    for (int e = 0; e < kNumEnds; ++e) {
      visualization_msgs::Marker m;
      m.header.stamp = stamp;
      m.header.frame_id = cfg_.world_frame;
      m.ns = labelName(static_cast<EndLabel>(e));
      m.id = e;
      m.type = visualization_msgs::Marker::MESH_RESOURCE;
      m.mesh_resource = std::string("package://drill_pipe_pose/models/") + m.ns + ".stl";
      m.scale.x = m.scale.y = m.scale.z = 1.0;
      m.color.a = 0.8f;
      m.color.r = e == 0 ? 0.1f : 1.0f;
      m.color.g = e == 0 ? 0.6f : 0.4f;
      m.color.b = e == 0 ? 1.0f : 0.1f;
      if (r.ends[e].valid) {
        m.action = visualization_msgs::Marker::ADD;
        m.pose = tf2::toMsg(r.ends[e].T_world_end);
        setTypeMesh(r.ends[e], &m);
      } else {
        m.action = visualization_msgs::Marker::DELETE;
      }
      ma.markers.push_back(m);
      for (auto& extra : axisAndLabel(m, r.ends[e])) ma.markers.push_back(std::move(extra));
    }
    otherEndMarkers(r, stamp, &ma);
    // Each camera's colour frustum (to frustum_range), in its optical frame.
    for (size_t i = 0; i < inputs.size(); ++i) {
      const CameraInfoData& ci = inputs[i].frame.color_info;
      if (!(ci.K[0] > 0 && ci.K[4] > 0) || ci.width == 0 || ci.height == 0) continue;
      visualization_msgs::Marker m;
      m.header.stamp = stamp;
      m.header.frame_id =
          !ci.frame_id.empty() ? ci.frame_id : inputs[i].frame.frame_id;
      m.ns = "camera " + inputs[i].frame.camera;
      m.id = 0;
      m.type = visualization_msgs::Marker::LINE_LIST;
      m.action = visualization_msgs::Marker::ADD;
      m.pose.orientation.w = 1.0;
      m.scale.x = 0.02;
      m.color.a = 0.7f;
      m.color.r = m.color.g = m.color.b = 0.85f;
      m.lifetime = ros::Duration(1.0);
      const double z = cfg_.debug_frustum_length;
      std::array<geometry_msgs::Point, 4> c;
      const double us[4] = {0, double(ci.width), double(ci.width), 0};
      const double vs[4] = {0, 0, double(ci.height), double(ci.height)};
      for (int k = 0; k < 4; ++k) {
        c[k].x = (us[k] - ci.K[2]) / ci.K[0] * z;
        c[k].y = (vs[k] - ci.K[5]) / ci.K[4] * z;
        c[k].z = z;
      }
      const geometry_msgs::Point o;
      for (int k = 0; k < 4; ++k) {
        m.points.push_back(o);
        m.points.push_back(c[k]);
        m.points.push_back(c[k]);
        m.points.push_back(c[(k + 1) % 4]);
      }
      ma.markers.push_back(m);
      visualization_msgs::Marker label = m;
      label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
      label.ns = "camera names";
      label.id = static_cast<int>(i);
      label.header.frame_id = m.header.frame_id;
      label.points.clear();
      label.scale.z = 0.25;
      label.text = inputs[i].frame.camera;
      ma.markers.push_back(label);
    }
    // Status text above the work zone: each end's state in a line.
    visualization_msgs::Marker text;
    text.header.stamp = stamp;
    text.header.frame_id = cfg_.world_frame;
    text.ns = "status";
    text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    text.action = visualization_msgs::Marker::ADD;
    const Eigen::Vector3d top = 0.5 * (cfg_.estimator.work_zone.min + cfg_.estimator.work_zone.max);
    const bool bounded = (cfg_.estimator.work_zone.max - cfg_.estimator.work_zone.min).maxCoeff() < 100.0;
    text.pose.position.x = bounded ? top.x() : 0.0;
    text.pose.position.y = bounded ? top.y() : 0.0;
    text.pose.position.z = bounded ? cfg_.estimator.work_zone.max.z() : 3.0;
    text.pose.orientation.w = 1.0;
    text.scale.z = 0.2;
    text.color.a = text.color.r = text.color.g = text.color.b = 1.0f;
    char line[256];
    for (int e = 0; e < kNumEnds; ++e) {
      const EndEstimate& est = r.ends[e];
      if (est.valid)
        std::snprintf(line, sizeof(line), "%s: %zu points, %zu cameras, residual %.1f mm\n",
                      labelName(est.label), est.points, est.cameras.size(), est.residual * 1e3);
      else
        std::snprintf(line, sizeof(line), "%s: invalid (%.80s)\n", labelName(est.label),
                      est.reason.c_str());
      text.text += line;
    }
    std::snprintf(line, sizeof(line), "%zu/%zu cameras, %.1f ms", r.cameras_used.size(),
                  cfg_.cameras.size(), r.timing.total_ms);
    text.text += line;
    ma.markers.push_back(text);
    marker_pub_.publish(ma);
  }


  void publishDiagnostics() {
    diagnostic_msgs::DiagnosticArray arr;
    arr.header.stamp = ros::Time::now();
    const double now = wallNow();
    for (const auto& cam : cfg_.cameras) {
      const CameraSyncStats& st = runner_.sync().stats().at(cam);
      Counters& cnt = counters_[cam];
      diagnostic_msgs::DiagnosticStatus s;
      s.name = "drill_pipe_pose: camera " + cam;
      s.hardware_id = cam;
      const uint64_t received = st.received - cnt.received_at_last_diag;
      const double rate = static_cast<double>(received) / std::max(1e-3, now - last_diag_wall_);
      cnt.received_at_last_diag = st.received;
      const std::string recent = noteRecentProblems(st, received, now, &cnt);
      if (st.received == 0) {
        s.level = diagnostic_msgs::DiagnosticStatus::ERROR;
        s.message = "no SensorFrame received yet on " + conventions::sensorFrameTopic(cam);
      } else if (!st.live) {
        s.level = diagnostic_msgs::DiagnosticStatus::ERROR;
        s.message = "silent for " + std::to_string(now - st.last_arrival) + " s: left the fusion";
      } else if (drift_.count(cam) && drift_.at(cam).flagged) {
        const CameraDriftStatus& d = drift_.at(cam);
        s.level = diagnostic_msgs::DiagnosticStatus::WARN;
        s.message = "disagrees with the fused fit (" + describeDrift(d) + "): moved since its " +
                    "calibration? " + (d.left_out ? "left out of the fit" : "still in the fit");
      } else if (!recent.empty()) {
        s.level = diagnostic_msgs::DiagnosticStatus::WARN;
        s.message = recent;
      } else {
        s.level = diagnostic_msgs::DiagnosticStatus::OK;
        s.message = "ok";
      }
      auto kv = [&](const std::string& k, const std::string& v) {
        diagnostic_msgs::KeyValue x;
        x.key = k;
        x.value = v;
        s.values.push_back(x);
      };
      kv("rate [Hz]", std::to_string(rate));
      kv("last stamp [s]", std::to_string(st.last_stamp_ns * 1e-9));
      kv("received", std::to_string(st.received));
      kv("used in cycles", std::to_string(st.used));
      kv("dropped: too late for its cycle", std::to_string(st.dropped_stale));
      kv("dropped: buffer overflow", std::to_string(st.dropped_overflow));
      kv("dropped: bad input", std::to_string(cnt.bad_input));
      kv("dropped: TF lookup failed", std::to_string(cnt.tf_failures));
      if (drift_.count(cam)) {
        const CameraDriftStatus& d = drift_.at(cam);
        kv("drift: shift along the view ray [mm]", std::to_string(d.ray_shift * 1e3));
        kv("drift: rotation [deg]", std::to_string(d.rotation));
        kv("drift: flagged", d.flagged ? "true" : "false");
        kv("drift: left out of the fit", d.left_out ? "true" : "false");
      }
      arr.status.push_back(s);
    }
    arr.status.push_back(clockStatus(now));
    last_diag_wall_ = now;
    diag_pub_.publish(arr);
    if (runner_.sync().liveCameras().empty() && throttle("no live camera", 10.0))
      ROS_WARN(
          "pose_estimator: no live camera (throttled, 10 s): is anything publishing "
          "<cam>/sensor_frame? (see /diagnostics)");
  }

  /// The node's clock as /diagnostics sees it: WARN for kJumpHold s after the clock jumped back
  /// (a looped bag, a clock reset), when buffers, tracks and poses were reset; else OK.
  diagnostic_msgs::DiagnosticStatus clockStatus(double now) const {
    // [s] long enough for a 1 Hz reader to see it, short enough not to hide the next one.
    constexpr double kJumpHold = 5.0;
    diagnostic_msgs::DiagnosticStatus s;
    s.name = "drill_pipe_pose: clock";
    s.hardware_id = "clock";
    if (clock_.jumps_back > 0 && now - clock_.last_jump_wall <= kJumpHold) {
      s.level = diagnostic_msgs::DiagnosticStatus::WARN;
      s.message = "time jumped back " + std::to_string(clock_.last_jump_s) +
                  " s (a looped bag or a clock reset): buffers, tracks and poses were reset";
    } else {
      s.level = diagnostic_msgs::DiagnosticStatus::OK;
      s.message = "ok";
    }
    diagnostic_msgs::KeyValue n, last;
    n.key = "jumps back";
    n.value = std::to_string(clock_.jumps_back);
    last.key = "last jump back [s]";
    last.value = std::to_string(clock_.last_jump_s);
    s.values = {n, last};
    return s;
  }

  /// A camera's problems of the last kProblemHold s, as a /diagnostics message ("" when none):
  /// TF lookups that failed, bad input, and frames too late for their cycle (at least
  /// kLateShare of the frames since the last tick: a lagging clock or network, not one frame
  /// delayed on a loaded machine). Updates the counts and times in `cnt`.
  static std::string noteRecentProblems(const CameraSyncStats& st, uint64_t received, double now,
                                        Counters* cnt) {
    // [s] a WARN outlives its problem by this long: a tick or two at 1 Hz, so that a
    // problem in every other second still reads as one.
    constexpr double kProblemHold = 2.0;
    // A stray late frame (a loaded machine) must not WARN, a lagging camera must: the faults
    // rostest's camera 300 ms late had 26 of 26 frames late in a second (seed 89).
    constexpr double kLateShare = 0.1;
    if (cnt->tf_failures > cnt->tf_at_diag) cnt->tf_seen = now;
    if (cnt->bad_input > cnt->bad_at_diag) cnt->bad_seen = now;
    const uint64_t late = st.dropped_stale - cnt->stale_at_diag;
    if (late > 0 && static_cast<double>(late) >= kLateShare * static_cast<double>(received)) {
      cnt->late_seen = now;
      cnt->late_text = std::to_string(late) + " of " + std::to_string(received);
    }
    cnt->tf_at_diag = cnt->tf_failures;
    cnt->bad_at_diag = cnt->bad_input;
    cnt->stale_at_diag = st.dropped_stale;
    std::string msg;
    auto add = [&](double seen, const std::string& what) {
      if (now - seen <= kProblemHold) msg += (msg.empty() ? "" : "; ") + what;
    };
    add(cnt->tf_seen, "frames dropped: TF lookup failed (see the log)");
    add(cnt->bad_seen, "frames dropped: bad input (see the log)");
    add(cnt->late_seen, "frames arrive too late for their cycle (" + cnt->late_text +
                            " in a second): a lagging clock or network?");
    return msg;
  }

  /// True at most once per `period` wall-clock seconds per key. (ROS_*_THROTTLE follows
  /// ros::Time, which under a simulated clock that jumps back stays silent for as long.)
  bool throttle(const std::string& key, double period) {
    const double now = ros::WallTime::now().toSec();
    auto it = throttle_last_.find(key);
    if (it != throttle_last_.end() && now - it->second < period) return false;
    throttle_last_[key] = now;
    return true;
  }

  /// /tf_static also goes into a buffer of our own: tf2_ros clears its buffer, static transforms
  /// included, when the clock jumps back (a looped bag), possibly after the bag re-sent them.
  void onStaticTf(const tf2_msgs::TFMessageConstPtr& msg) {
    for (const auto& t : msg->transforms) tf_.add(t, true);
  }

  ros::NodeHandle nh_, pnh_;
  NodeConfig cfg_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  TfTransforms tf_;  ///< /tf_static (onStaticTf), then tf_buffer_
  CycleRunner runner_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::map<std::string, double> throttle_last_;                       ///< wall time [s] by key
  ros::Subscriber static_tf_sub_;
  std::map<std::string, ros::Subscriber> subs_;  ///< per camera
  std::array<ros::Publisher, kNumEnds> pose_pubs_;
  ros::Publisher ends_pub_, types_pub_, status_pub_, diag_pub_, fused_pub_, segmented_pub_, marker_pub_;
  ros::WallTimer poll_timer_, diag_timer_;
  std::map<std::string, Counters> counters_;
  std::map<std::string, CameraDriftStatus> drift_;  ///< the drift watch's last status per camera
  /// Per "<type>_<label>": the file:// URL of the type's model (setTypeMesh; empty: not written).
  std::map<std::string, std::string> type_meshes_;
  double last_diag_wall_ = wallNow();
  double last_none_live_ = 0;  ///< [s] wall clock of the last poll with no camera live
  struct ClockJumps {
    uint64_t jumps_back = 0;
    double last_jump_s = 0;      ///< [s] how far the last jump went back
    double last_jump_wall = 0;   ///< [s] wall clock when it was seen
  } clock_;
};

}  // namespace
}  // namespace drill_pipe_pose

int main(int argc, char** argv) {
  ros::init(argc, argv, "pose_estimator");
  try {
    drill_pipe_pose::PoseEstimatorNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    // Also on stderr: ROS_FATAL may not reach the console while the node shuts down.
    ROS_FATAL("pose_estimator: %s", e.what());
    std::fprintf(stderr, "pose_estimator: %s\n", e.what());
    return 1;
  }
  return 0;
}
