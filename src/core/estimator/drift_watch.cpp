// The drift watch (drift_watch.hpp): per-camera shift observations against the fitted models,
// and their running estimates and flags.

#include "drill_pipe_pose/core/estimator/drift_watch.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "drill_pipe_pose/core/metrics.hpp"

namespace drill_pipe_pose {

namespace {

/// Largest number of a camera's points read per end (every k-th): the mean of 800 points'
/// residuals is well below the millimetre, and the cost stays a fraction of a cycle's.
constexpr size_t kMaxPoints = 800;
/// The second pass keeps points within this fraction of the gate of the first pass's surface
/// (clutter near the joint - a floor, a hand - out of the estimate once the shift is known).
constexpr double kSecondGate = 0.3;
/// Alignment passes (the shift changes by well under a millimetre after the fourth on the
/// unit test's 2 cm shifts).
constexpr int kIterations = 5;
/// Cameras measured in a cycle from which their common shift along the ray is taken off.
constexpr size_t kMinCommon = 3;

/// Unit normal n (world) of the surface at the point's closest model point and the distance d
/// along it (point = closest + d n); false outside the trusted part or the surface's reach.
bool surfaceResidual(const Eigen::Vector3d& p, const FittedSurface& s, Eigen::Vector3d* n,
                     double* d) {
  if (p.z() < s.min_world_z) return false;
  const Eigen::Vector3d v = p - s.origin;
  const double zc = v.dot(s.z);
  if (zc < s.min_z) return false;
  const Eigen::Vector3d radial = v - zc * s.z;
  const double r = radial.norm();
  if (r < 1e-6) return false;
  Eigen::Vector2d g;
  *d = s.model->distance(zc, r, &g);
  *n = g.x() * s.z + g.y() * (radial / r);
  return true;
}

}  // namespace

void ShiftObservation::add(const ShiftObservation& o) {
  A += o.A;
  b += o.b;
  ray_sum += o.ray_sum;
  range_sum += o.range_sum;
  points += o.points;
}

Eigen::Vector3d ShiftObservation::solve() const {
  if (points == 0) return Eigen::Vector3d::Zero();
  const double ridge = 0.005 * static_cast<double>(points);
  return (A + ridge * Eigen::Matrix3d::Identity()).ldlt().solve(b);
}

ShiftObservation observeShift(const std::vector<Eigen::Vector3f>& points,
                              const Eigen::Vector3d& eye, const FittedSurface& surface,
                              double gate) {
  ShiftObservation out;
  if (!surface.model || points.empty()) return out;
  const size_t step = (points.size() + kMaxPoints - 1) / kMaxPoints;
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(std::min(points.size(), kMaxPoints));
  for (size_t i = 0; i < points.size(); i += step) pts.push_back(points[i].cast<double>());
  // A small ICP on the translation: the closest model points are found again for the points
  // moved back by the shift so far (a 2 cm shift into the joint's wall finds the end face
  // closest, not the side it came from), the first pass within the gate, the others within
  // kSecondGate of it.
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  ShiftObservation pass;
  for (int iter = 0; iter < kIterations; ++iter) {
    pass = ShiftObservation();
    const double g = iter == 0 ? gate : kSecondGate * gate;
    for (const Eigen::Vector3d& p : pts) {
      Eigen::Vector3d n;
      double d = 0;
      if (!surfaceResidual(p - t, surface, &n, &d) || std::abs(d) > g) continue;
      pass.A += n * n.transpose();
      pass.b += n * d;
      ++pass.points;
    }
    if (pass.points == 0) return out;
    t += pass.solve();
  }
  const Eigen::Vector3d to_end = surface.origin - eye;
  const double range = to_end.norm();
  const Eigen::Vector3d u = range > 0 ? Eigen::Vector3d(to_end / range) : Eigen::Vector3d::UnitZ();
  // The last pass's normal equations about t (b = A t + its residual): they solve to t, and
  // add up with another end's.
  out.A = pass.A;
  out.b = pass.A * t + pass.b;
  out.points = pass.points;
  out.ray_sum = static_cast<double>(pass.points) * u;
  out.range_sum = static_cast<double>(pass.points) * range;
  return out;
}

void DriftWatch::updateByEnd(int64_t stamp_ns, const DriftObservations& observations) {
  for (auto& [name, s] : cams_) {
    s.measured = false;
    s.points = 0;
  }
  struct Sample {
    double ray = 0, range = 0;
    Eigen::Vector3d lateral = Eigen::Vector3d::Zero();
    size_t points = 0;
    unsigned ends = 0;  ///< bit e: end e measured
  };
  std::map<std::string, Sample> samples;
  std::vector<double> rays;
  for (const auto& [name, per_end] : observations) {
    cams_[name].camera = name;
    // The camera's ends, their normal equations added up.
    ShiftObservation obs;
    unsigned ends = 0;
    for (int e = 0; e < kNumEnds; ++e)
      if (per_end[e].points > 0) {
        obs.add(per_end[e]);
        ends |= 1u << e;
      }
    if (obs.points < config_.min_points || obs.range_sum <= 0) continue;
    const Eigen::Vector3d t = obs.solve();
    const Eigen::Vector3d u = obs.ray_sum.normalized();
    Sample& sm = samples[name];
    sm.ray = t.dot(u);
    sm.lateral = t - sm.ray * u;
    sm.range = obs.range_sum / static_cast<double>(obs.points);
    sm.points = obs.points;
    sm.ends = ends;
    rays.push_back(sm.ray);
  }
  // What every camera shares along its ray is no camera's drift (a joint a little thicker than
  // the model, a depth bias of the sensor type: about -10 mm in every camera of the simulated
  // thesis_vertical, kinect_v2_calibrated, seed 61): with kMinCommon cameras or more, the
  // median is taken off each.
  const double common = rays.size() >= kMinCommon ? upperMedian(std::move(rays)) : 0.0;
  for (const auto& [name, sm] : samples)
    updateCamera(stamp_ns, sm.ends, sm.ray - common, sm.lateral / sm.range, sm.points,
                 &cams_[name]);
}

void DriftWatch::updateCamera(int64_t stamp_ns, unsigned ends, double ray,
                              const Eigen::Vector3d& angle, size_t points,
                              CameraDriftStatus* st) {
  CameraDriftStatus& s = *st;
  const auto weight = [stamp_ns](int64_t last_ns, double time_constant) {
    const double dt =
        last_ns > 0 && stamp_ns > last_ns ? static_cast<double>(stamp_ns - last_ns) * 1e-9 : 0.0;
    return 1.0 - std::exp(-std::min(dt, 5.0 * time_constant) / time_constant);
  };
  // The baseline of the ends the camera measured in this cycle: a camera's view of each end has
  // its own bias, so the camera has a baseline per set of ends (box, pin, both). It is the
  // plain mean of the set's samples over its first learn_time seconds of capture time; after
  // that it follows them with baseline_time_constant (0: never) while the camera is not
  // flagged. A set seen for the first time later (an end that comes into view) is learned then:
  // its cycles change the camera's disagreement, not its shift.
  SetBaseline& b = baselines_[s.camera][ends & (kEndSets - 1)];
  if (b.samples == 0) b.first_stamp_ns = stamp_ns;
  ++b.samples;
  b.learning = static_cast<double>(stamp_ns - b.first_stamp_ns) * 1e-9 < config_.learn_time;
  if (b.learning) {
    const double ab = 1.0 / static_cast<double>(b.samples);
    b.ray += ab * (ray - b.ray);
    b.angle += ab * (angle - b.angle);
  } else if (!s.flagged && config_.baseline_time_constant > 0) {
    const double ab = weight(b.last_stamp_ns, config_.baseline_time_constant);
    b.ray += ab * (ray - b.ray);
    b.angle += ab * (angle - b.angle);
  }
  b.last_stamp_ns = stamp_ns;
  if (s.samples == 0) s.first_stamp_ns = stamp_ns;
  ++s.samples;
  // Exponential weight over capture time; while no set is learned, at least the plain mean's.
  double a = weight(s.last_stamp_ns, config_.time_constant);
  s.learning = true;
  for (const SetBaseline& x : baselines_[s.camera])
    s.learning = s.learning && (x.samples == 0 || x.learning);
  if (s.learning) a = std::max(a, 1.0 / static_cast<double>(s.samples));
  s.disagreement_ray += a * (ray - s.disagreement_ray);
  s.disagreement_lateral += a * (angle - s.disagreement_lateral);  // an angle: the range varies
  if (!b.learning) {
    // One cycle's sample moves the running shift by at most a * kMaxStep limits: a robust
    // running mean. A bump of up to kMaxStep limits passes whole; a single wild sample does not
    // flag a camera (catwalk_horizontal, seed 61, with the amplitude model: cam5's one sample
    // about 70 mm off its baseline, with the pin end seen by 4 cameras, lifted its shift from 6.0
    // to 10.5 mm in one cycle). kMaxStep: 2, the smallest bump bench_drift must name (2 cm).
    constexpr double kMaxStep = 2.0;
    const double ray_step = kMaxStep * config_.max_ray_shift;
    s.ray_shift += a * std::clamp((ray - b.ray) - s.ray_shift, -ray_step, ray_step);
    Eigen::Vector3d step = (angle - b.angle) - s.lateral;
    const double max_step = kMaxStep * config_.max_rotation * M_PI / 180.0;
    if (step.norm() > max_step) step *= max_step / step.norm();
    s.lateral += a * step;
  }
  s.baseline_ray = b.ray;
  s.baseline_lateral = b.angle;
  s.rotation = s.lateral.norm() * 180.0 / M_PI;
  s.last_stamp_ns = stamp_ns;
  s.measured = true;
  s.points = points;
  const double ray_lim = config_.max_ray_shift, rot_lim = config_.max_rotation;
  const double absolute = absoluteExcess(s);
  if (!s.flagged && !s.learning &&
      (std::abs(s.ray_shift) > ray_lim || s.rotation > rot_lim || absolute > 1.0)) {
    s.flagged = true;
    s.flagged_since_ns = stamp_ns;
  } else if (s.flagged && std::abs(s.ray_shift) < config_.release_fraction * ray_lim &&
             s.rotation < config_.release_fraction * rot_lim &&
             absolute < config_.release_fraction) {
    s.flagged = false;
    s.flagged_since_ns = 0;
  }
}

double DriftWatch::absoluteExcess(const CameraDriftStatus& s) const {
  const double f = config_.absolute_factor;
  return std::max(std::abs(s.disagreement_ray) / (f * config_.max_ray_shift),
                  s.disagreement_lateral.norm() * 180.0 / M_PI / (f * config_.max_rotation));
}

bool DriftWatch::flagged(const std::string& camera) const {
  const auto it = cams_.find(camera);
  return it != cams_.end() && it->second.flagged;
}

double DriftWatch::excess(const std::string& camera) const {
  const auto it = cams_.find(camera);
  if (it == cams_.end()) return 0.0;
  return std::max({std::abs(it->second.ray_shift) / config_.max_ray_shift,
                   it->second.rotation / config_.max_rotation, absoluteExcess(it->second)});
}

std::vector<CameraDriftStatus> DriftWatch::status() const {
  std::vector<CameraDriftStatus> out;
  out.reserve(cams_.size());
  for (const auto& [name, s] : cams_) out.push_back(s);
  return out;
}

std::string describeDrift(const CameraDriftStatus& s) {
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "shift along the view ray %+.1f mm, rotation %.2f deg since its baseline "
                "(disagreement %+.1f mm, %.2f deg)",
                s.ray_shift * 1e3, s.rotation, s.disagreement_ray * 1e3,
                s.disagreement_lateral.norm() * 180.0 / M_PI);
  return buf;
}

}  // namespace drill_pipe_pose
