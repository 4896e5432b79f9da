#include "drill_pipe_pose/core/cycle_runner.hpp"

#include <exception>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"
#include "drill_pipe_pose/core/rig_calibration.hpp"

namespace drill_pipe_pose {

namespace {
const EstimatorNodeConfig& validated(const EstimatorNodeConfig& config) {
  validateEstimatorNodeConfig(config);
  return config;
}

/// The estimator's configuration with its pipe types resolved from the catalogue (pipe_catalog;
/// the node and the tools set the package's when it is empty). Without a catalogue the default
/// type alone is known (its figures are tool_joint/*'s defaults): no classification.
EstimatorConfig withPipeTypes(EstimatorConfig c) {
  if (c.pipe_type.empty()) return c;
  if (c.pipe_catalog.empty()) {
    if (c.pipe_type == EstimatorConfig().pipe_type) return c;
    fail("estimator config: tool_joint/type = ", c.pipe_type,
         " needs the pipe catalogue: set pipe_catalog to config/pipe_catalog.yaml's path");
  }
  resolvePipeTypes(&c, loadPipeCatalog(c.pipe_catalog));
  validateConfig(c);
  return c;
}

}  // namespace

CycleRunner::CycleRunner(const EstimatorNodeConfig& config, TransformSource* transforms)
    : config_(validated(config)),
      estimator_(withPipeTypes(config.estimator)),
      sync_(config.cameras, config.sync),
      transforms_(transforms) {
  if (!transforms_) fail("cycle runner: no transform source");
  if (config_.rig.empty()) return;
  const RigCalibration rig = loadRigCalibration(config_.rig);
  for (const std::string& name : config_.cameras) {
    const int i = rig.find(name);  // the rig file names cameras as the sensor nodes are named
    if (i < 0) {
      cameras_without_correction_.push_back(name);
      continue;
    }
    const CameraCalibration& c = rig.cameras[i];
    depth_corrections_[name] =
        DepthCorrection{c.depth_offset, c.depth_scale, c.weak_return_bias.value_or(-1.0)};
  }
}

std::string CycleRunner::tallyWarning() const {
  const std::vector<std::string>& names = config_.estimator.pipe_types;
  return drill_pipe_pose::tallyWarning(estimator_.config().candidates,
                                       names.size() == 1 && names[0] == "all");
}

void CycleRunner::reset() {
  sync_.reset();
  sync_.takeDropped();  // every pending frame: the store is cleared below
  store_.clear();
  estimator_.reset();
  for (auto& l : last_) l.reset();
  last_cycle_stamp_ns_ = 0;
}

AddResult CycleRunner::add(const std::string& camera, int64_t stamp_ns, double arrival,
                           FrameLoader load) {
  AddResult r;
  if (last_cycle_stamp_ns_ > 0 && stamp_ns < last_cycle_stamp_ns_ - 1000000000LL) {
    r.time_jumped_back = true;
    r.jump_s = static_cast<double>(last_cycle_stamp_ns_ - stamp_ns) * 1e-9;
    reset();
  }
  const uint64_t id = next_id_++;
  store_[id] = {camera, std::move(load)};
  r.accepted = sync_.add(camera, stamp_ns, arrival, id);
  for (auto dropped : sync_.takeDropped()) store_.erase(dropped);
  return r;
}

std::vector<CycleOutput> CycleRunner::poll(double now) {
  std::vector<CycleOutput> out;
  for (const auto& cycle : sync_.poll(now)) out.push_back(run(cycle));
  for (auto id : sync_.takeDropped()) store_.erase(id);
  return out;
}

std::optional<CameraInput> CycleRunner::assemble(const std::string& camera,
                                                 const FrameLoader& load,
                                                 std::vector<InputProblem>* problems) {
  CameraInput in;
  const auto correction = depth_corrections_.find(camera);
  if (correction != depth_corrections_.end()) in.depth_correction = correction->second;
  try {
    in.frame = load();
  } catch (const std::exception& e) {
    problems->push_back({InputProblem::Kind::kBadInput, camera, e.what()});
    return std::nullopt;
  }
  // The frames as a sensor node names them; older nodes leave the message-level ids empty.
  const std::string depth_frame =
      !in.frame.depth_frame_id.empty() ? in.frame.depth_frame_id : in.frame.depth_info.frame_id;
  const std::string color_frame =
      !in.frame.color_info.frame_id.empty() ? in.frame.color_info.frame_id : in.frame.frame_id;
  const int64_t stamp = in.frame.depth_stamp_ns ? in.frame.depth_stamp_ns : in.frame.stamp_ns;
  try {
    in.T_world_depth = transforms_->lookup(config_.world_frame, depth_frame, stamp);
    in.T_color_depth = transforms_->lookup(color_frame, depth_frame, stamp);
  } catch (const std::exception& e) {
    problems->push_back({InputProblem::Kind::kTransform, camera,
                         config_.world_frame + " <- '" + depth_frame + "' and '" + color_frame +
                             "' <- '" + depth_frame + "': " + e.what()});
    return std::nullopt;
  }
  return in;
}

CycleOutput CycleRunner::run(const FrameSynchronizer::Cycle& cycle) {
  CycleOutput out;
  out.cycle = cycle;
  for (const auto& [cam, id] : cycle.frames) {
    auto it = store_.find(id);
    if (it == store_.end()) {
      out.problems.push_back({InputProblem::Kind::kBadInput, cam,
                              "frame " + std::to_string(id) + " is gone from the store"});
      continue;
    }
    if (auto in = assemble(cam, it->second.second, &out.problems))
      out.inputs.push_back(std::move(*in));
    store_.erase(it);
  }
  out.result = estimator_.process(out.inputs);
  last_cycle_stamp_ns_ = cycle.stamp_ns;
  for (int e = 0; e < kNumEnds; ++e)
    out.ends[e] = publishEnd(e, out.result.ends[e], cycle.stamp_ns);
  if (out.ends[0].valid && out.ends[1].valid)
    out.pin_in_box =
        pinInBox(out.ends[0].estimate.T_world_end, out.ends[1].estimate.T_world_end);
  return out;
}

PublishedEnd CycleRunner::publishEnd(int e, const EndEstimate& fresh, int64_t stamp_ns) {
  PublishedEnd p;
  p.estimate = fresh;
  if (fresh.valid) last_[e] = LastPose{fresh, stamp_ns};
  const double age = last_[e] ? static_cast<double>(stamp_ns - last_[e]->stamp_ns) * 1e-9 : 0.0;
  if (last_[e] && age <= config_.max_pose_age) {
    p.valid = true;
    p.fresh = fresh.valid;
    p.age = age;
    p.estimate = last_[e]->estimate;
    if (!fresh.valid)
      p.message = "not seen this cycle (" + fresh.reason + "); last pose repeated";
    else if (fresh.label_corrected)
      p.message = "label corrected by geometry";
  } else {
    p.age = last_[e] ? age : 0.0;
    p.message = last_[e] ? "last pose too old; " + fresh.reason : fresh.reason;
  }
  return p;
}

}  // namespace drill_pipe_pose
