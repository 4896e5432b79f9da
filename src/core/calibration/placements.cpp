#include "drill_pipe_pose/core/calibration/placements.hpp"

#include <algorithm>
#include <map>
#include <numeric>
#include <string>
#include <utility>

#include "drill_pipe_pose/core/metrics.hpp"

namespace drill_pipe_pose::calibration {

namespace {

/// Indices of `frames` sorted by stamp (stable: equal stamps keep their order).
std::vector<size_t> byStamp(const std::vector<Observation>& frames) {
  std::vector<size_t> order(frames.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return frames[a].stamp < frames[b].stamp; });
  return order;
}

/// True when `b` shows the same corners as `a` within `max_px`: at least 6 shared ids (a PnP's
/// minimum in the solver), three quarters of either frame's corners, every shared one within.
bool sameCorners(const Observation& a, const Observation& b, double max_px) {
  if (a.corners.empty() || b.corners.empty()) return false;
  std::map<int, Eigen::Vector2d> uv;
  for (const CornerObservation& c : a.corners) uv[c.id] = c.uv;
  size_t shared = 0;
  for (const CornerObservation& c : b.corners) {
    const auto it = uv.find(c.id);
    if (it == uv.end()) continue;
    if ((it->second - c.uv).norm() > max_px) return false;
    ++shared;
  }
  return shared >= 6 && 4 * shared >= 3 * std::max(a.corners.size(), b.corners.size());
}

/// The median interval between a camera's consecutive frames (0 when no camera has two).
double medianPeriod(const std::vector<Observation>& frames, const std::vector<size_t>& order) {
  std::map<std::string, double> last;
  std::vector<double> dt;
  for (size_t i : order) {
    const auto it = last.find(frames[i].camera);
    if (it != last.end() && frames[i].stamp > it->second) dt.push_back(frames[i].stamp - it->second);
    last[frames[i].camera] = frames[i].stamp;
  }
  return upperMedian(std::move(dt));
}

}  // namespace

PlacementGroups groupPlacements(const std::vector<Observation>& frames,
                                const PlacementOptions& options) {
  PlacementGroups g;
  g.placement.assign(frames.size(), -1);
  const std::vector<size_t> order = byStamp(frames);
  g.frame_period = options.frame_period > 0 ? options.frame_period : medianPeriod(frames, order);
  const double max_gap = options.gap_frame_periods * g.frame_period;
  std::map<std::string, size_t> previous;  // camera -> its previous frame
  double last_still = 0.0;
  for (size_t i : order) {
    const Observation& f = frames[i];
    const auto prev = previous.find(f.camera);
    const bool still = prev != previous.end() &&
                       sameCorners(frames[prev->second], f, options.max_corner_motion_px);
    previous[f.camera] = i;
    if (!still) continue;
    if (g.count == 0 || f.stamp - last_still > max_gap) ++g.count;
    g.placement[i] = g.count - 1;
    last_still = f.stamp;
  }
  return g;
}

std::vector<Observation> selectObservations(const std::vector<Observation>& frames,
                                            const PlacementGroups& groups, int max_frames) {
  // (placement, camera) -> its still frames, best first
  std::map<std::pair<int, std::string>, std::vector<size_t>> still;
  for (size_t i = 0; i < frames.size(); ++i)
    if (groups.placement.at(i) >= 0) still[{groups.placement[i], frames[i].camera}].push_back(i);
  std::vector<size_t> chosen;
  for (auto& [key, list] : still) {
    std::stable_sort(list.begin(), list.end(), [&](size_t a, size_t b) {
      return frames[a].corners.size() > frames[b].corners.size() ||
             (frames[a].corners.size() == frames[b].corners.size() &&
              frames[a].stamp < frames[b].stamp);
    });
    for (size_t k = 0; k < list.size() && static_cast<int>(k) < max_frames; ++k)
      chosen.push_back(list[k]);
  }
  std::stable_sort(chosen.begin(), chosen.end(), [&](size_t a, size_t b) {
    return groups.placement[a] < groups.placement[b] ||
           (groups.placement[a] == groups.placement[b] && a < b);
  });
  std::vector<Observation> out;
  for (size_t i : chosen) {
    out.push_back(frames[i]);
    out.back().placement = groups.placement[i];
  }
  return out;
}

}  // namespace drill_pipe_pose::calibration
