#pragma once
// Cycle forming over N unsynchronised cameras (docs/conventions.md, "Cycle"), ROS-free so it is
// unit-tested and reused by the node and the bench. Per-camera buffers, never a hard N-way
// synchroniser: a dead or late camera never stalls output.
//
// A cycle is anchored at the oldest pending capture stamp t_a and takes from each camera its
// oldest frame with stamp in [t_a, t_a + window) (a second one, from jitter, waits for the next
// cycle). It closes as soon as every LIVE camera has a
// frame in the window (or has already sent a newer one), or when `max_wait` has passed (arrival
// clock) since its first frame arrived. It is stamped with the latest capture stamp it used.
// A camera silent for longer than `camera_timeout` (arrival clock) leaves the fusion and rejoins
// with its next frame; one that has never sent a frame leaves it once `max_wait` has passed
// since the first frame (a camera dead from the start holds no cycle after the first).

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

namespace drill_pipe_pose {

/// Sensor-node rate limit on a capture-time grid shared by every node: a frame is processed when
/// it is the first of its 1/max_rate slot (floor(stamp * max_rate) differs from that of the last
/// processed frame, or time went back). Every node then picks frames of the same moment, which
/// the central node fuses into one cycle. max_rate <= 0 or last_ns <= 0: every frame.
bool takeFrameAtRate(int64_t stamp_ns, int64_t last_ns, double max_rate);

struct FrameSyncConfig {
  double window = 1.0 / 30.0;   ///< [s] capture-stamp span of one cycle (one sensor period)
  double max_wait = 0.05;       ///< [s] arrival time a cycle waits for late cameras
  double camera_timeout = 1.0;  ///< [s] silence after which a camera leaves the fusion
  size_t buffer_size = 8;       ///< frames kept per camera (older ones are dropped and counted)
};

/// Why frames were dropped, per camera (for /diagnostics).
struct CameraSyncStats {
  uint64_t received = 0;
  uint64_t used = 0;
  uint64_t dropped_stale = 0;     ///< older than the last closed cycle (too late / out of order)
  uint64_t dropped_overflow = 0;  ///< buffer full
  int64_t last_stamp_ns = 0;
  double last_arrival = 0;  ///< [s] arrival clock
  bool live = false;
};

/// Frames are referred to by an opaque id the caller chooses (e.g. an index into its storage).
class FrameSynchronizer {
 public:
  struct Cycle {
    int64_t stamp_ns = 0;     ///< latest capture stamp used
    double last_arrival = 0;  ///< [s] arrival of the cycle's last frame (latency reference)
    std::vector<std::pair<std::string, uint64_t>> frames;  ///< (camera, frame id)
    bool complete = false;  ///< closed because every live camera contributed (not by timeout)
  };

  FrameSynchronizer(const std::vector<std::string>& cameras, const FrameSyncConfig& config);

  /// Adds a frame of `camera` captured at `stamp_ns`, arriving at `arrival` [s]. Returns false
  /// (and counts it) when the frame is too old to be used or the camera is unknown.
  bool add(const std::string& camera, int64_t stamp_ns, double arrival, uint64_t frame_id);

  /// Closes every cycle that is ready at arrival time `now` [s], oldest first.
  std::vector<Cycle> poll(double now);

  /// Forgets all pending frames and the stamp history (e.g. after the clock jumped back); the
  /// next frame starts afresh, every camera expected again as at start-up.
  void reset();

  const std::map<std::string, CameraSyncStats>& stats() const { return stats_; }
  std::vector<std::string> liveCameras() const;
  /// Frame ids dropped since the last call (so the caller can free their storage).
  std::vector<uint64_t> takeDropped();

 private:
  struct Pending {
    int64_t stamp_ns;
    double arrival;
    uint64_t id;
  };
  void updateLiveness(double now);

  FrameSyncConfig config_;
  std::vector<std::string> cameras_;
  std::map<std::string, std::deque<Pending>> buffers_;
  std::map<std::string, CameraSyncStats> stats_;
  int64_t closed_until_ns_ = INT64_MIN;  ///< frames with stamps below this are stale
  bool started_ = false;
  std::vector<uint64_t> dropped_;
};

}  // namespace drill_pipe_pose
