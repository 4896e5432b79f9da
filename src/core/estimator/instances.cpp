// Instances of a label: clusters of its carved points.
//
// Not pcl::EuclideanClusterExtraction: with the tolerance needed to keep a joint whole (several
// centimetres) its radius searches return hundreds of neighbours per point, and a cycle's ~3000
// points took 17 ms. Connected occupied cells of a hash grid take well under a millisecond.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "drill_pipe_pose/core/estimator/stages.hpp"

namespace drill_pipe_pose {

std::vector<std::vector<size_t>> euclideanClusters(const std::vector<CloudPoint>& points,
                                                   double tolerance, size_t min_points) {
  std::vector<std::vector<size_t>> out;
  if (points.empty() || points.size() < min_points || !(tolerance > 0)) return out;
  // Cells of edge `tolerance`; two occupied cells that touch (26-neighbourhood) join.
  auto key = [](int64_t x, int64_t y, int64_t z) {
    return (static_cast<uint64_t>(x & 0x1FFFFF) << 42) | (static_cast<uint64_t>(y & 0x1FFFFF) << 21) |
           static_cast<uint64_t>(z & 0x1FFFFF);
  };
  std::unordered_map<uint64_t, int> cell_of;  // cell key -> cell index
  std::vector<std::array<int64_t, 3>> cells;
  std::vector<int> point_cell(points.size());
  cell_of.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i].p_world;
    const std::array<int64_t, 3> c{{static_cast<int64_t>(std::floor(p.x() / tolerance)),
                                    static_cast<int64_t>(std::floor(p.y() / tolerance)),
                                    static_cast<int64_t>(std::floor(p.z() / tolerance))}};
    auto [it, inserted] = cell_of.emplace(key(c[0], c[1], c[2]), static_cast<int>(cells.size()));
    if (inserted) cells.push_back(c);
    point_cell[i] = it->second;
  }
  std::vector<int> parent(cells.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (size_t k = 0; k < cells.size(); ++k)
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = cell_of.find(key(cells[k][0] + dx, cells[k][1] + dy, cells[k][2] + dz));
          if (it == cell_of.end()) continue;
          const int a = find(static_cast<int>(k)), b = find(it->second);
          if (a != b) parent[std::max(a, b)] = std::min(a, b);
        }
  std::unordered_map<int, size_t> cluster_of_root;
  std::vector<std::vector<size_t>> all;
  for (size_t i = 0; i < points.size(); ++i) {
    const int r = find(point_cell[i]);
    auto [it, inserted] = cluster_of_root.emplace(r, all.size());
    if (inserted) all.emplace_back();
    all[it->second].push_back(i);  // ascending: i increases
  }
  for (auto& c : all)
    if (c.size() >= min_points) out.push_back(std::move(c));
  // Largest first; equal sizes by their first point (deterministic).
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.size() != b.size() ? a.size() > b.size() : a.front() < b.front();
  });
  return out;
}

}  // namespace drill_pipe_pose
