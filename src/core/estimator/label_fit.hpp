#pragma once
// Stage "instances" for one detected label: its carved points split into instances, the one its
// track follows fitted first, the largest others decided, and the label's candidate chosen among
// them (private to the estimator's sources).

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "candidate.hpp"
#include "drill_pipe_pose/core/estimator/instances.hpp"
#include "drill_pipe_pose/core/estimator/pipe_type.hpp"
#include "drill_pipe_pose/core/estimator/track.hpp"

namespace drill_pipe_pose {

/// Another end of a label's model in the work zone, besides the label's candidate (several
/// pipes at once): its own track, instance id and type evidence.
struct OtherEnd {
  Track track;
  uint32_t id = 0;  ///< instance id (never reused)
  /// Its pipe type (index into the candidates; its label's when it is created), whose models its
  /// fits use (CycleContext::type_models).
  int type = -1;
  TypeEvidence evidence;  ///< measured against that model
  SearchedRadii measured;  ///< its searched joint radii (measureJointRadius), absolute
  int decisions = 0;      ///< its decisions since its searched radii were sure (searchDue)
  int fits = 0;  ///< fits followed; published from instances.confirm_fits on
};

/// A fit of an OtherEnd this cycle: `other` indexes LabelState::others, -1 for a new end.
struct OtherFit {
  int other = -1;
  Candidate cd;
  uint32_t id = 0;  ///< for a new end: the id it keeps (a primary end that became an other)
};

/// What lives across cycles for one detected label.
struct LabelState {
  Track track;
  std::vector<OtherEnd> others;  ///< the label's other ends (fitted with its model)
  std::vector<InstanceMemory> memory;  ///< what the decisions showed of each instance
  /// Clusters tried as new other ends outside a decision whose fit failed: (centroid [m],
  /// capture stamp). None near one is tried again for tracking.max_gap.
  std::vector<std::pair<Eigen::Vector3d, int64_t>> failed_starts;
  /// Consecutive decisions whose fit took the other model against the label's last fit of its
  /// own (a label correction waits for instances.min_decisions of them).
  int flips = 0;
};

/// Label `label`'s candidate for this cycle from its cut-out (`raw`) and carved points [world]:
/// a continuing track follows the instance at its prediction; otherwise the largest instances
/// are decided and the best-fitting valid one chosen (chooseInstance, which updates
/// state->memory). Reads state->track and state->others, writes state->memory only: the two
/// labels run in parallel. `instances` receives the number of instances found. `others`
/// receives the fits of the label's other ends: each continuing OtherEnd's track follows its
/// cluster (the clusters not taken by the label's track), and a decision's valid fits that were
/// not chosen and lie in no other track's cluster start new ones; in a cycle without a decision,
/// every cluster no track follows is fitted as a new one (away from state->failed_starts, which
/// it updates).
Candidate fitLabel(const CycleContext& ctx, int label, const std::vector<CloudPoint>& raw,
                   const std::vector<CloudPoint>& carved, LabelState* state,
                   LabelTiming* timing, uint32_t* instances, std::vector<OtherFit>* others);

}  // namespace drill_pipe_pose
