#include "drill_pipe_pose/core/estimator/track.hpp"

namespace drill_pipe_pose {

bool Track::recent(int64_t t, double max_gap) const {
  const double g = gap(t);
  return stamp_ns > 0 && g > 0 && g <= max_gap;
}

bool Track::fitWithin(int64_t t, double max_gap) const {
  const double g = gap(t);
  return stamp_ns > 0 && g >= 0 && g <= max_gap;
}

bool Track::continues(int64_t t, double max_gap) const {
  const double g = gap(t);
  return valid && g > 0 && g <= max_gap;
}

Eigen::Vector3d Track::predict(int64_t t, double max_prediction) const {
  Eigen::Vector3d move = velocity * gap(t);
  if (move.norm() > max_prediction) move *= max_prediction / move.norm();
  return origin + move;
}

void Track::follow(int64_t t, const TrackedFit& fit, double max_gap, double max_offset) {
  const double g = gap(t);
  const bool continuing = continues(t, max_gap) && model == fit.model && z.dot(fit.z) > 0 &&
                          (fit.origin - predict(t)).norm() <= max_offset;
  // The mean velocity also survives cycles without a fit (a moving end's fit is rejected now
  // and then): the same end, as predicted, within max_gap.
  const bool resumed = recent(t, max_gap) && model == fit.model && z.dot(fit.z) > 0 &&
                       (fit.origin - predict(t)).norm() <= max_offset;
  velocity = continuing ? Eigen::Vector3d((fit.origin - origin) / g) : Eigen::Vector3d::Zero();
  if (resumed) {
    Eigen::Vector3d v = (fit.origin - origin) / g;
    if (v.norm() > kMeanVelocityCap) v *= kMeanVelocityCap / v.norm();
    mean_velocity += kMeanVelocityWeight * (v - mean_velocity);
  } else {
    mean_velocity.setZero();
  }
  cycles = fit.tracked ? cycles + 1 : 1;
  if (!fit.tracked) direction_margin = fit.direction_margin;
  valid = true;
  model = fit.model;
  origin = fit.origin;
  z = fit.z;
  stamp_ns = t;
  has_support = fit.has_support;
  support_z = fit.support_z;
}

}  // namespace drill_pipe_pose
