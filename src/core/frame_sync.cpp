#include "drill_pipe_pose/core/frame_sync.hpp"

#include <algorithm>
#include <climits>
#include <cmath>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

bool takeFrameAtRate(int64_t stamp_ns, int64_t last_ns, double max_rate) {
  if (!(max_rate > 0) || last_ns <= 0 || stamp_ns <= last_ns) return true;
  auto slot = [&](int64_t ns) { return std::floor(static_cast<double>(ns) * 1e-9 * max_rate); };
  return slot(stamp_ns) != slot(last_ns);
}

FrameSynchronizer::FrameSynchronizer(const std::vector<std::string>& cameras,
                                     const FrameSyncConfig& config)
    : config_(config), cameras_(cameras) {
  if (cameras.empty()) fail("frame sync: the list of cameras is empty");
  if (!(config.window > 0) || !(config.max_wait >= 0) || !(config.camera_timeout > 0) ||
      config.buffer_size == 0)
    fail("frame sync: window = ", config.window, ", max_wait = ", config.max_wait,
         ", camera_timeout = ", config.camera_timeout, ", buffer_size = ", config.buffer_size,
         " (window and camera_timeout must be > 0, max_wait >= 0, buffer_size >= 1)");
  for (const auto& c : cameras) {
    if (buffers_.count(c)) fail("frame sync: camera '", c, "' is listed twice");
    buffers_[c];
    stats_[c];
  }
}

bool FrameSynchronizer::add(const std::string& camera, int64_t stamp_ns, double arrival,
                            uint64_t id) {
  auto it = buffers_.find(camera);
  if (it == buffers_.end()) return false;
  if (!started_) {
    // Every configured camera is expected from the first frame on, so that the first cycle
    // waits for all of them; one that has never sent a frame leaves the fusion once max_wait
    // has passed (updateLiveness): a camera dead from the start must not hold the cycles of
    // its first camera_timeout (two of six silent cameras held 29 cycles for 50 ms each).
    started_ = true;
    for (auto& [cam, st] : stats_) {
      st.live = true;
      st.last_arrival = arrival;
    }
  }
  CameraSyncStats& st = stats_[camera];
  ++st.received;
  st.last_arrival = arrival;
  st.live = true;
  st.last_stamp_ns = std::max(st.last_stamp_ns, stamp_ns);
  if (stamp_ns < closed_until_ns_) {
    ++st.dropped_stale;
    dropped_.push_back(id);
    return false;
  }
  auto& buf = it->second;
  const auto pos = std::upper_bound(buf.begin(), buf.end(), stamp_ns,
                                    [](int64_t s, const Pending& p) { return s < p.stamp_ns; });
  buf.insert(pos, Pending{stamp_ns, arrival, id});
  if (buf.size() > config_.buffer_size) {
    ++st.dropped_overflow;
    dropped_.push_back(buf.front().id);
    buf.pop_front();
  }
  return true;
}

void FrameSynchronizer::updateLiveness(double now) {
  for (auto& [cam, st] : stats_) {
    const double timeout = st.received == 0 ? config_.max_wait : config_.camera_timeout;
    if (st.live && now - st.last_arrival > timeout && buffers_[cam].empty()) st.live = false;
  }
}

std::vector<FrameSynchronizer::Cycle> FrameSynchronizer::poll(double now) {
  std::vector<Cycle> out;
  updateLiveness(now);
  const int64_t window_ns = static_cast<int64_t>(std::llround(config_.window * 1e9));
  for (;;) {
    // Anchor: the oldest pending stamp over all cameras.
    int64_t anchor = INT64_MAX;
    double first_arrival = 1e300;
    for (const auto& [cam, buf] : buffers_)
      if (!buf.empty()) {
        anchor = std::min(anchor, buf.front().stamp_ns);
        for (const auto& p : buf) first_arrival = std::min(first_arrival, p.arrival);
      }
    if (anchor == INT64_MAX) return out;
    const int64_t end = anchor + window_ns;
    // Complete when every live camera has a frame in the window or one beyond it.
    bool complete = true;
    for (const auto& cam : cameras_) {
      const auto& buf = buffers_[cam];
      const bool has = !buf.empty() && buf.front().stamp_ns < end;
      const bool beyond = !buf.empty() && buf.back().stamp_ns >= end;
      if (stats_[cam].live && !has && !beyond) complete = false;
    }
    if (!complete && now - first_arrival < config_.max_wait) return out;
    Cycle c;
    c.complete = complete;
    c.stamp_ns = INT64_MIN;
    for (const auto& cam : cameras_) {
      // The camera's oldest frame in the window; a second one (jitter) waits for the next cycle.
      auto& buf = buffers_[cam];
      if (buf.empty() || buf.front().stamp_ns >= end) continue;
      const Pending p = buf.front();
      buf.pop_front();
      c.frames.emplace_back(cam, p.id);
      c.stamp_ns = std::max(c.stamp_ns, p.stamp_ns);
      c.last_arrival = std::max(c.last_arrival, p.arrival);
      ++stats_[cam].used;
    }
    closed_until_ns_ = anchor + 1;
    out.push_back(c);
  }
}

void FrameSynchronizer::reset() {
  for (auto& [cam, buf] : buffers_) {
    for (const auto& p : buf) dropped_.push_back(p.id);
    buf.clear();
  }
  closed_until_ns_ = INT64_MIN;
  // As at start-up: the next frame makes every camera live again, so that the first cycle waits
  // for all of them (cameras silent for camera_timeout before the reset would otherwise not be
  // waited for, and the first cycle would close with the first frame alone).
  started_ = false;
}

std::vector<std::string> FrameSynchronizer::liveCameras() const {
  std::vector<std::string> live;
  for (const auto& cam : cameras_)
    if (stats_.at(cam).live) live.push_back(cam);
  return live;
}

std::vector<uint64_t> FrameSynchronizer::takeDropped() {
  std::vector<uint64_t> d;
  d.swap(dropped_);
  return d;
}

}  // namespace drill_pipe_pose
