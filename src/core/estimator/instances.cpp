// Instances of a label: clusters of its carved points, and the choice among them.
//
// Not pcl::EuclideanClusterExtraction: with the tolerance needed to keep a joint whole (several
// centimetres) its radius searches return hundreds of neighbours per point, and a cycle's ~3000
// points took 17 ms. Connected occupied cells of a hash grid take well under a millisecond.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include "drill_pipe_pose/core/estimator/stages.hpp"
#include "drill_pipe_pose/core/estimator/support_plane.hpp"

namespace drill_pipe_pose {

namespace {

using GridCell = std::array<int64_t, 3>;

/// The cell of a grid of edge `edge` [m] that holds p.
GridCell cellOf(const Eigen::Vector3f& p, double edge) {
  return {{static_cast<int64_t>(std::floor(p.x() / edge)),
           static_cast<int64_t>(std::floor(p.y() / edge)),
           static_cast<int64_t>(std::floor(p.z() / edge))}};
}

/// A cell's hash key: 21 bits per axis (cells repeat every 2^21 edges, far beyond a work zone).
uint64_t cellKey(const GridCell& c) {
  return (static_cast<uint64_t>(c[0] & 0x1FFFFF) << 42) |
         (static_cast<uint64_t>(c[1] & 0x1FFFFF) << 21) | static_cast<uint64_t>(c[2] & 0x1FFFFF);
}

}  // namespace

std::vector<std::vector<size_t>> euclideanClusters(const std::vector<CloudPoint>& points,
                                                   double tolerance, size_t min_points) {
  std::vector<std::vector<size_t>> out;
  if (points.empty() || points.size() < min_points || !(tolerance > 0)) return out;
  // Cells of edge `tolerance`; two occupied cells that touch (26-neighbourhood) join.
  std::unordered_map<uint64_t, int> cell_of;  // cell key -> cell index
  std::vector<GridCell> cells;
  std::vector<int> point_cell(points.size());
  cell_of.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const GridCell c = cellOf(points[i].p_world, tolerance);
    auto [it, inserted] = cell_of.emplace(cellKey(c), static_cast<int>(cells.size()));
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
          auto it = cell_of.find(cellKey({{cells[k][0] + dx, cells[k][1] + dy, cells[k][2] + dz}}));
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

namespace {

/// One cluster split where a level support joins it (splitAtSupport); empty when it does not.
std::vector<std::vector<size_t>> splitOne(const std::vector<CloudPoint>& points,
                                          const std::vector<size_t>& cluster, double tolerance,
                                          size_t min_points, double min_separation,
                                          const EstimatorConfig::AxisFit& ac) {
  std::vector<Eigen::Vector3f> pts;
  pts.reserve(cluster.size());
  for (size_t i : cluster) pts.push_back(points[i].p_world);
  const std::vector<size_t> layer = levelSupportPoints(pts, ac);
  if (layer.empty()) return {};
  // Point density is judged in cells of half the clustering's edge (4 cm by default), chosen
  // with kDenseCell below on catwalk_twin seed 120.
  const double edge = 0.5 * tolerance;
  // Loose points (flying pixels at depth edges, stray noise) join neighbouring cells one by one
  // and would bridge the pipes again: the split is made of the points in cells holding at least
  // kDenseCell of them, and the loose ones are assigned after. Chosen on catwalk_twin seed 120
  // among 3, 4, 6 and 8: every end reported in 76, 68, 87 and 73 % of end-cycles; a joint's
  // cell holds dozens.
  constexpr int kDenseCell = 6;
  std::vector<uint8_t> assign_after(cluster.size(), 0);
  for (size_t j : layer) assign_after[j] = 1;
  std::unordered_map<uint64_t, int> count;
  for (size_t j = 0; j < cluster.size(); ++j)
    if (!assign_after[j]) ++count[cellKey(cellOf(pts[j], edge))];
  for (size_t j = 0; j < cluster.size(); ++j)
    if (!assign_after[j] && count[cellKey(cellOf(pts[j], edge))] < kDenseCell) assign_after[j] = 1;
  std::vector<CloudPoint> rest;
  std::vector<size_t> rest_index;  // into `points`
  for (size_t j = 0; j < cluster.size(); ++j)
    if (!assign_after[j]) rest.push_back(points[cluster[j]]), rest_index.push_back(cluster[j]);
  std::vector<std::vector<size_t>> parts = euclideanClusters(rest, tolerance, min_points);
  if (parts.size() < 2) return {};
  // Parts nearer than one joint's diameter are sides of one joint (its near and far side, with
  // the sparse points between them left out: thesis_vertical, seed 17), not two pipes.
  std::vector<Eigen::Vector3f> centroid;
  for (const auto& part : parts) {
    Eigen::Vector3f m = Eigen::Vector3f::Zero();
    for (size_t r : part) m += rest[r].p_world;
    centroid.push_back(m / static_cast<float>(part.size()));
  }
  for (size_t a = 0; a < parts.size(); ++a)
    for (size_t b = a + 1; b < parts.size(); ++b)
      if ((centroid[a] - centroid[b]).norm() < min_separation) return {};
  // Each part's points per cell of the clustering's edge (their sum, for the cell's centroid):
  // the points left out above go to the part with the nearest centroid in a neighbouring cell,
  // so that each part keeps the support around its joint (findLevelSupport).
  struct Cell {
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    int n = 0;
    int part = -1;
  };
  std::unordered_map<uint64_t, Cell> cells;
  for (size_t k = 0; k < parts.size(); ++k)
    for (size_t& r : parts[k]) {
      Cell& c = cells[cellKey(cellOf(rest[r].p_world, tolerance))];
      if (c.part < 0) c.part = static_cast<int>(k);
      if (c.part == static_cast<int>(k)) {  // a cell of two parts: the first part's centroid
        c.sum += rest[r].p_world;
        ++c.n;
      }
      r = rest_index[r];  // now an index into `points`
    }
  for (size_t j = 0; j < cluster.size(); ++j) {
    if (!assign_after[j]) continue;
    const Eigen::Vector3f& p = pts[j];
    const GridCell c0 = cellOf(p, tolerance);
    int best = -1;
    float best_d2 = std::numeric_limits<float>::infinity();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = cells.find(cellKey({{c0[0] + dx, c0[1] + dy, c0[2] + dz}}));
          if (it == cells.end() || it->second.n == 0) continue;
          const float d2 = (it->second.sum / static_cast<float>(it->second.n) - p).squaredNorm();
          if (d2 < best_d2) best_d2 = d2, best = it->second.part;
        }
    if (best >= 0) parts[static_cast<size_t>(best)].push_back(cluster[j]);
  }
  for (auto& part : parts) std::sort(part.begin(), part.end());
  return parts;
}

}  // namespace

std::vector<std::vector<size_t>> splitAtSupport(const std::vector<CloudPoint>& points,
                                                std::vector<std::vector<size_t>> clusters,
                                                double tolerance, size_t min_points,
                                                double min_separation,
                                                const EstimatorConfig::AxisFit& axis_fit) {
  std::vector<std::vector<size_t>> out;
  bool split = false;
  for (auto& c : clusters) {
    std::vector<std::vector<size_t>> parts =
        splitOne(points, c, tolerance, min_points, min_separation, axis_fit);
    if (parts.empty()) {
      out.push_back(std::move(c));
      continue;
    }
    split = true;
    for (auto& p : parts) out.push_back(std::move(p));
  }
  if (split)
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
      return a.size() != b.size() ? a.size() > b.size() : a.front() < b.front();
    });
  return out;
}

namespace {

std::string at(const Eigen::Vector3d& o) {
  std::ostringstream s;
  s.precision(3);
  s << "(" << o.x() << ", " << o.y() << ", " << o.z() << ")";
  return s.str();
}

}  // namespace

const InstanceMemory* otherSize(const InstanceMemory& entry,
                                const std::vector<InstanceMemory>& memory,
                                const EstimatorConfig::Instances& ic) {
  if (!(ic.radius_difference > 0) || entry.radius_samples < ic.min_decisions) return nullptr;
  // Squared standard error of a mean radius. A joint's first few measurements scatter by
  // 1-2 mm (cluttered's lying 4.5" pipe read 0.2 mm and 2.8 mm under the 5" model, the 5" pin
  // end 3.1 mm and 1.5 mm over it), so three of them can make the right size look like another.
  auto squared_error = [](const InstanceMemory& m) {
    return m.radius_samples > 1 ? m.radius_variance / (m.radius_samples - 1) : 0.0;
  };
  for (const InstanceMemory& o : memory) {
    if (&o == &entry || o.radius_samples < ic.min_decisions ||
        !(std::abs(o.radius_offset) < std::abs(entry.radius_offset)))
      continue;
    // Two standard errors: a plain ~95 % significance level, not tuned.
    const double margin = 2.0 * std::sqrt(squared_error(entry) + squared_error(o));
    if (std::abs(entry.radius_offset - o.radius_offset) > ic.radius_difference + margin) return &o;
  }
  return nullptr;
}

const InstanceMemory* reversedAgainst(const Eigen::Vector3d& origin, const Eigen::Vector3d& z,
                                      const std::vector<InstanceMemory>& memory,
                                      int64_t stamp_ns, const EstimatorConfig::Instances& ic) {
  if (!(ic.reversal_reach > 0)) return nullptr;
  const InstanceMemory* against = nullptr;
  for (const InstanceMemory& e : memory) {
    const double age = static_cast<double>(stamp_ns - e.stamp_ns) * 1e-9;
    if (!(age >= 0 && age <= ic.memory_s)) continue;
    const Eigen::Vector3d q = origin - e.origin;
    if (e.z.dot(z) > 0) {
      if (q.norm() <= ic.track_gate) return nullptr;  // its own entry
      continue;
    }
    const double along = q.dot(e.z);
    if (e.decisions >= ic.min_decisions && std::abs(along) <= ic.reversal_reach &&
        (q - along * e.z).norm() <= ic.track_gate)
      against = &e;
  }
  return against;
}

namespace {

/// Ends a and b on one axis line: their unit axes within max_angle_deg of parallel (`facing`
/// false) or antiparallel (true), each origin within `reach` of the line through the other along
/// their mean axis; *along gets the origins' distance along it. False on degenerate input.
bool onOneAxisLine(const Eigen::Vector3d& a_origin, const Eigen::Vector3d& a_z,
                   const Eigen::Vector3d& b_origin, const Eigen::Vector3d& b_z, bool facing,
                   double reach, double max_angle_deg, double* along) {
  const double an = a_z.norm(), bn = b_z.norm();
  if (!(an > 0 && bn > 0) || !(reach >= 0)) return false;
  const Eigen::Vector3d a = a_z / an, b = (facing ? -b_z : b_z) / bn;
  if (!(a.dot(b) >= std::cos(max_angle_deg * M_PI / 180.0))) return false;
  const Eigen::Vector3d axis = (a + b).normalized();
  const Eigen::Vector3d d = b_origin - a_origin;
  *along = std::abs(d.dot(axis));
  return (d - d.dot(axis) * axis).norm() <= reach;
}

}  // namespace

bool coaxialEnds(const Eigen::Vector3d& a_origin, const Eigen::Vector3d& a_z,
                 const Eigen::Vector3d& b_origin, const Eigen::Vector3d& b_z, double reach,
                 double max_angle_deg) {
  double along = 0;
  return onOneAxisLine(a_origin, a_z, b_origin, b_z, true, reach, max_angle_deg, &along);
}

bool endsOnOneJoint(const Eigen::Vector3d& a_origin, const Eigen::Vector3d& a_z,
                    const Eigen::Vector3d& b_origin, const Eigen::Vector3d& b_z, double reach,
                    double along, double max_angle_deg) {
  double apart = 0;
  return onOneAxisLine(a_origin, a_z, b_origin, b_z, false, reach, max_angle_deg, &apart) &&
         apart < along;
}

namespace {

/// One candidate of the choice: a fit of this cycle (with its memory entry) or a remembered entry.
struct Competitor {
  int fit = -1;    // index into fits; -1: a memory entry with no fit this cycle
  size_t mem = 0;  // index into memory
  double mean = 0.0;
  int decisions = 0;
};

/// Forgets the entries not decided for instances.memory_s (or stamped after stamp_ns).
void forgetStale(std::vector<InstanceMemory>* memory, int64_t stamp_ns,
                 const EstimatorConfig::Instances& ic) {
  memory->erase(std::remove_if(memory->begin(), memory->end(),
                               [&](const InstanceMemory& m) {
                                 const double age =
                                     static_cast<double>(stamp_ns - m.stamp_ns) * 1e-9;
                                 return !(age >= 0 && age <= ic.memory_s);
                               }),
                memory->end());
}

/// Each competing fit joins its memory entry (the nearest within instances.track_gate, or a new
/// one): its running means of cost and radius, origin and stamp. Returns the fits as
/// competitors; `updated` marks the entries they joined.
std::vector<Competitor> joinFits(std::vector<InstanceMemory>* memory_ptr,
                                 const std::vector<InstanceFit>& fits, int64_t stamp_ns,
                                 const EstimatorConfig::Instances& ic,
                                 std::vector<bool>* updated) {
  std::vector<InstanceMemory>& memory = *memory_ptr;
  std::vector<Competitor> comp;
  updated->assign(memory.size(), false);
  for (size_t k = 0; k < fits.size(); ++k) {
    if (!fits[k].competes) continue;
    int m = -1;
    double m_d = ic.track_gate;
    for (size_t e = 0; e < memory.size(); ++e) {
      const double d = (memory[e].origin - fits[k].origin).norm();
      if (d <= m_d) m_d = d, m = static_cast<int>(e);
    }
    if (m < 0) {
      memory.emplace_back();
      updated->push_back(false);
      m = static_cast<int>(memory.size()) - 1;
    }
    InstanceMemory& e = memory[m];
    e.decisions = std::min(e.decisions + 1, ic.memory_decisions);
    e.mean_cost += (fits[k].cost - e.mean_cost) / e.decisions;
    if (fits[k].radius.ok) {
      e.radius_samples = std::min(e.radius_samples + 1, ic.memory_decisions);
      const double x = fits[k].radius.offset, before = e.radius_offset;
      e.radius_offset += (x - before) / e.radius_samples;
      e.radius_variance +=
          ((x - before) * (x - e.radius_offset) - e.radius_variance) / e.radius_samples;
    }
    e.origin = fits[k].origin;
    e.z = fits[k].z;
    e.stamp_ns = stamp_ns;
    (*updated)[m] = true;
    comp.push_back({static_cast<int>(k), static_cast<size_t>(m), e.mean_cost, e.decisions});
  }
  return comp;
}

/// Removes the competitors that another entry shows to be another pipe size (otherSize);
/// `excluded` and `nearer` receive the last one removed and the entry that ruled it out.
void excludeOtherSizes(std::vector<Competitor>* comp, const std::vector<InstanceMemory>& memory,
                       const EstimatorConfig::Instances& ic, int* excluded,
                       const InstanceMemory** nearer) {
  for (size_t c = 0; c < comp->size();) {
    if (const InstanceMemory* o = otherSize(memory[(*comp)[c].mem], memory, ic)) {
      *excluded = static_cast<int>((*comp)[c].mem);
      *nearer = o;
      comp->erase(comp->begin() + static_cast<std::ptrdiff_t>(c));
    } else {
      ++c;
    }
  }
}

}  // namespace

InstanceChoice chooseInstance(std::vector<InstanceMemory>* memory_ptr,
                              const std::vector<InstanceFit>& fits, int track, int64_t stamp_ns,
                              const PointsNear& points_near, size_t min_points,
                              const EstimatorConfig::Instances& ic, const std::string& label) {
  std::vector<InstanceMemory>& memory = *memory_ptr;
  forgetStale(&memory, stamp_ns, ic);
  std::vector<bool> updated;
  std::vector<Competitor> comp = joinFits(&memory, fits, stamp_ns, ic, &updated);
  InstanceChoice choice;
  if (comp.empty()) return choice;
  // An entry with no fit this cycle whose place still holds the label's points: with enough
  // decisions it competes; with fewer it is a candidate not known yet (its points carved away
  // this cycle, say). It, and an instance fitted this cycle that does not compete (its fit
  // failed or took the other model), can keep a newcomer from being taken (the rule below).
  bool failed_fit = false, undecided_entry = false;
  for (const InstanceFit& f : fits) failed_fit = failed_fit || !f.competes;
  for (size_t e = 0; e < memory.size(); ++e) {
    if (updated[e] || points_near(memory[e].origin, ic.track_gate) < min_points) continue;
    if (memory[e].decisions >= ic.min_decisions)
      comp.push_back({-1, e, memory[e].mean_cost, memory[e].decisions});
    else
      undecided_entry = true;
  }
  // Another pipe size does not compete.
  int excluded = -1;
  const InstanceMemory* nearer = nullptr;
  excludeOtherSizes(&comp, memory, ic, &excluded, &nearer);
  if (comp.empty()) {
    const InstanceMemory& e = memory[static_cast<size_t>(excluded)];
    std::ostringstream s;
    s.precision(3);
    s << "the " << label << " instance at " << at(e.origin) << " is another pipe size: its "
      << "tool joint's radius measures " << (e.radius_offset - nearer->radius_offset) * 1e3
      << " mm off that of the one at " << at(nearer->origin) << ", which is nearer the model's "
      << "(means of " << e.radius_samples << " and " << nearer->radius_samples
      << " decisions; instances.radius_difference = " << ic.radius_difference * 1e3 << " mm)";
    choice.reason = s.str();
    return choice;
  }
  std::stable_sort(comp.begin(), comp.end(),
                   [](const Competitor& a, const Competitor& b) { return a.mean < b.mean; });
  auto take = [&](size_t c) {
    for (auto& e : memory) e.chosen = false;
    memory[comp[c].mem].chosen = true;
    choice.index = comp[c].fit;
    return choice;
  };
  const Eigen::Vector3d& best_at = memory[comp[0].mem].origin;
  // The incumbent keeps its place unless clearly beaten.
  const bool track_competes =
      track >= 0 && static_cast<size_t>(track) < fits.size() && fits[track].competes;
  int incumbent = -1;
  for (size_t c = 0; c < comp.size(); ++c)
    if (comp[c].fit >= 0 && (track_competes ? comp[c].fit == track : memory[comp[c].mem].chosen))
      incumbent = static_cast<int>(c);
  if (incumbent >= 0) {
    const bool challenged = incumbent != 0 && comp[0].decisions >= ic.min_decisions &&
                            (1.0 + ic.min_cost_margin) * comp[0].mean <= comp[incumbent].mean;
    if (!challenged) return take(static_cast<size_t>(incumbent));
  }
  std::ostringstream s;
  s.precision(3);
  if (comp[0].fit < 0) {
    s << "the " << label << " instance at " << at(best_at) << " fits best (mean truncated squared "
      << "residual " << comp[0].mean * 1e6 << " mm^2 over its last " << comp[0].decisions
      << " decisions) but has no fit this cycle; not taking another in its place";
    choice.reason = s.str();
    return choice;
  }
  // Not yet: the best is not known well enough among others; or, without an incumbent, another
  // is not (its decisions - its radius too - may still rule the best out). A failed fit holds
  // the choice only while the best is new (it may fail every cycle: a detection on clutter).
  int fewest = comp[0].decisions;
  for (const Competitor& c : comp) fewest = std::min(fewest, c.decisions);
  const bool best_new = comp[0].decisions < ic.min_decisions;
  const bool best_unknown = comp.size() > 1 && best_new;
  const bool other_unknown = incumbent < 0 && (undecided_entry || (failed_fit && best_new) ||
                                               (comp.size() > 1 && fewest < ic.min_decisions));
  const bool pending = undecided_entry || failed_fit;
  if (best_unknown || other_unknown) {
    s << comp.size() + (pending ? 1 : 0) << (pending ? " or more " : " ") << label
      << " instances in the work zone, not all decided in instances.min_decisions = "
      << ic.min_decisions << " cycles yet (the best fitting one at " << at(best_at) << " in "
      << comp[0].decisions << "): not choosing yet";
    choice.reason = s.str();
    return choice;
  }
  if (comp.size() > 1 && comp[1].mean < (1.0 + ic.min_cost_margin) * comp[0].mean) {
    s << label << " instances fit alike (mean truncated squared residual over their last "
      << "decisions, mm^2): " << comp[0].mean * 1e6 << " at " << at(best_at) << ", "
      << comp[1].mean * 1e6 << " at " << at(memory[comp[1].mem].origin)
      << "; not choosing (instances.min_cost_margin = " << ic.min_cost_margin
      << "; a narrower work_zone leaves the other out)";
    choice.reason = s.str();
    return choice;
  }
  return take(0);
}

}  // namespace drill_pipe_pose
