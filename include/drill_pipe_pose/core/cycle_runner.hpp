#pragma once
// One cycle runner for the node and the bench (ROS-free): frames in, synchronised into cycles,
// each camera's input assembled with its transforms, the estimator run, and the output policy
// applied - so that what bench_estimator measures is exactly what the node publishes.
//
// Output policy (the one definition of "valid", docs/conventions.md "Cycle"): an end is valid in
// a cycle when it has a pose no older than max_pose_age [s] of capture time - this cycle's fresh
// estimate, or the last one repeated. The estimator's fresh estimate is also kept (`fresh`).

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"
#include "drill_pipe_pose/core/estimator/pose_estimator.hpp"
#include "drill_pipe_pose/core/frame_sync.hpp"
#include "drill_pipe_pose/core/pipe_end_frame.hpp"

namespace drill_pipe_pose {

/// Transforms between frames at a capture time: the node plugs in tf2, the bench the bag's TF.
class TransformSource {
 public:
  virtual ~TransformSource() = default;
  /// T_target_source at stamp_ns [ns]; throws std::exception (naming the frames) when unknown.
  virtual Eigen::Isometry3d lookup(const std::string& target, const std::string& source,
                                   int64_t stamp_ns) = 0;
};

/// A waiting frame's content, converted only when the frame enters a cycle (a frame the
/// synchroniser drops is never converted). Throws InputError naming the camera and the field.
using FrameLoader = std::function<SensorFrameData()>;

/// A frame that could not enter its cycle.
struct InputProblem {
  enum class Kind { kBadInput, kTransform } kind = Kind::kBadInput;
  std::string camera;
  std::string message;
};

/// One end as published in one cycle.
struct PublishedEnd {
  bool valid = false;  ///< a pose no older than max_pose_age (fresh or repeated)
  bool fresh = false;  ///< the pose is this cycle's estimate
  double age = 0.0;    ///< [s] capture time since the pose's cycle (0 without one)
  EndEstimate estimate;  ///< the reported pose (with valid), else this cycle's invalid estimate
  std::string message;   ///< why invalid, or a note (repeated, label corrected)
};

/// Everything one cycle gives the node and the bench.
struct CycleOutput {
  FrameSynchronizer::Cycle cycle;
  CycleResult result;  ///< the estimator's output for this cycle
  std::array<PublishedEnd, kNumEnds> ends;
  std::optional<PinInBoxRelation> pin_in_box;  ///< when both ends are valid
  std::vector<CameraInput> inputs;             ///< the cycle's assembled inputs
  std::vector<InputProblem> problems;          ///< frames left out of the cycle
};

/// What CycleRunner::add did with a frame.
struct AddResult {
  bool accepted = true;  ///< false: too late for its cycle (counted by the synchroniser)
  /// The frame's stamp lies more than 1 s before the last cycle: time jumped back (a looped
  /// bag, a restarted simulator) and everything was reset before adding it.
  bool time_jumped_back = false;
  double jump_s = 0.0;  ///< [s] how far back
};

class CycleRunner {
 public:
  /// The node's configuration (the same for node and bench: cameras, world_frame, max_pose_age,
  /// sync/..., rig, estimator); validates it and loads the rig file when set (throws InputError
  /// naming the key, or the rig file and its field).
  CycleRunner(const EstimatorNodeConfig& config, TransformSource* transforms);

  /// A frame of `camera` captured at stamp_ns [ns] arrived at `arrival` [s, arrival clock].
  AddResult add(const std::string& camera, int64_t stamp_ns, double arrival, FrameLoader load);
  /// Runs every cycle that is ready at arrival time `now` [s], oldest first.
  std::vector<CycleOutput> poll(double now);
  /// Forgets pending frames, the estimator's state and the last poses.
  void reset();

  const FrameSynchronizer& sync() const { return sync_; }
  const EstimatorNodeConfig& config() const { return config_; }
  /// The pipe types the estimator may give an end (pipe_types resolved to catalogue entries).
  const std::vector<PipeCandidate>& candidates() const { return estimator_.config().candidates; }
  /// Each camera's depth calibration from config().rig (absent: none).
  const std::map<std::string, DepthCorrection>& depthCorrections() const {
    return depth_corrections_;
  }
  /// The start-up warning about the allowed pipe types (tallyWarning, pipe_type.hpp): "" when
  /// the sensor can tell every pair apart. For the caller to warn about, once.
  std::string tallyWarning() const;
  /// The cameras of config().cameras that config().rig (when set) does not list: their depth is
  /// read uncorrected. For the caller to warn about, once.
  const std::vector<std::string>& camerasWithoutDepthCorrection() const {
    return cameras_without_correction_;
  }

 private:
  struct LastPose {
    EndEstimate estimate;
    int64_t stamp_ns = 0;
  };
  /// Stage "input assembly": converts a frame and looks up its transforms, or a problem.
  std::optional<CameraInput> assemble(const std::string& camera, const FrameLoader& load,
                                      std::vector<InputProblem>* problems);
  CycleOutput run(const FrameSynchronizer::Cycle& cycle);
  /// The output policy for one end (see the file comment).
  PublishedEnd publishEnd(int e, const EndEstimate& fresh, int64_t stamp_ns);

  EstimatorNodeConfig config_;
  PoseEstimator estimator_;
  FrameSynchronizer sync_;
  TransformSource* transforms_;
  std::map<uint64_t, std::pair<std::string, FrameLoader>> store_;
  std::array<std::optional<LastPose>, kNumEnds> last_;
  std::map<std::string, DepthCorrection> depth_corrections_;
  std::vector<std::string> cameras_without_correction_;
  uint64_t next_id_ = 0;
  int64_t last_cycle_stamp_ns_ = 0;
};

}  // namespace drill_pipe_pose
