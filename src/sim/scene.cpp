#include "drill_pipe_pose/sim/scene.hpp"

#include <algorithm>
#include <cmath>

namespace drill_pipe_pose::sim {

namespace {

/// Key pose k held, then moving linearly to k + 1 (Trajectory::key_poses).
Eigen::Isometry3d keyPose(const std::vector<Eigen::Isometry3d>& keys, double hold_s,
                          double move_s, double t) {
  const double period = std::max(hold_s + move_s, 1e-9);
  const double k = std::floor(std::max(t, 0.0) / period);
  if (k >= static_cast<double>(keys.size() - 1)) return keys.back();
  const size_t i = static_cast<size_t>(k);
  const double s = std::max(t, 0.0) - k * period - hold_s;
  if (s <= 0.0 || move_s <= 0.0) return keys[i];
  const double a = std::min(s / move_s, 1.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = (1.0 - a) * keys[i].translation() + a * keys[i + 1].translation();
  T.linear() = Eigen::Quaterniond(keys[i].linear())
                   .slerp(a, Eigen::Quaterniond(keys[i + 1].linear()))
                   .toRotationMatrix();
  return T;
}

}  // namespace

Eigen::Isometry3d Trajectory::pose(double t) const {
  Eigen::Isometry3d T = T_world_anchor;
  if (!key_poses.empty()) {
    T = keyPose(key_poses, hold_s, move_s, t);
  } else if (!pose_sequence.empty()) {
    const double k = std::floor(std::max(t, 0.0) / std::max(pose_interval_s, 1e-9));
    T = pose_sequence[static_cast<size_t>(k) % pose_sequence.size()];
  }
  if (!velocity.isZero(0)) {
    const double tau = linear_period_s > 0.0 ? std::fmod(std::max(t, 0.0), linear_period_s) : t;
    T.pretranslate(velocity * tau);
  }
  if (swing_amplitude_rad != 0.0 && swing_period_s > 0.0) {
    const double angle = swing_amplitude_rad * std::sin(2.0 * M_PI * t / swing_period_s);
    const Eigen::Vector3d pivot = T.translation() + swing_pivot_offset;
    Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
    R.linear() = Eigen::AngleAxisd(angle, swing_axis.normalized()).toRotationMatrix();
    T = Eigen::Translation3d(pivot) * R * Eigen::Translation3d(-pivot) * T;
  }
  return T;
}

int Scene::addTrajectory(const Trajectory& traj) {
  if (traj.isStatic()) return -1;
  trajectories.push_back(traj);
  return static_cast<int>(trajectories.size()) - 1;
}

Eigen::Isometry3d Scene::objectPose(size_t i, double t) const {
  const SceneObject& o = objects[i];
  if (o.trajectory < 0) return o.T_anchor_object;
  return trajectories[o.trajectory].pose(t) * o.T_anchor_object;
}

Eigen::Isometry3d Scene::endPose(size_t i, double t) const {
  const SceneEnd& e = ends[i];
  if (e.trajectory < 0) return e.T_anchor_end;
  return trajectories[e.trajectory].pose(t) * e.T_anchor_end;
}

SceneSnapshot Scene::snapshot(double t) const {
  SceneSnapshot s;
  s.t = t;
  std::vector<Eigen::Isometry3d> traj(trajectories.size());
  for (size_t k = 0; k < trajectories.size(); ++k) traj[k] = trajectories[k].pose(t);
  const size_t n = objects.size();
  s.T_world_object.resize(n);
  s.T_object_world.resize(n);
  s.world_bounds.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const SceneObject& o = objects[i];
    s.T_world_object[i] =
        o.trajectory < 0 ? o.T_anchor_object : traj[o.trajectory] * o.T_anchor_object;
    s.T_object_world[i] = s.T_world_object[i].inverse();
    s.world_bounds[i] = transformBox(o.shape.localBounds(), s.T_world_object[i]);
  }
  return s;
}

bool Scene::intersect(const Ray& ray, const SceneSnapshot& snap, const std::vector<int>* subset,
                      double t_min, double t_max, SceneHit* hit) const {
  int best = -1;
  double best_t = t_max;
  LocalHit best_local;
  Ray best_ray_local;
  const size_t n = subset ? subset->size() : objects.size();
  for (size_t k = 0; k < n; ++k) {
    const int i = subset ? (*subset)[k] : static_cast<int>(k);
    double te, tx;
    if (!intersectSlabs(snap.world_bounds[i], ray, t_min, best_t, &te, &tx)) continue;
    const Eigen::Isometry3d& T_ow = snap.T_object_world[i];
    Ray local;
    local.o = T_ow * ray.o;
    local.d = T_ow.linear() * ray.d;
    LocalHit lh;
    if (objects[i].shape.intersect(local, t_min, best_t, &lh)) {
      best = i;
      best_t = lh.t;
      best_local = lh;
      best_ray_local = local;
    }
  }
  if (best < 0) return false;
  const SceneObject& o = objects[best];
  hit->t = best_t;
  hit->object = best;
  hit->n_world = snap.T_world_object[best].linear() * best_local.n;
  hit->p_local = best_ray_local.o + best_t * best_ray_local.d;
  hit->reflectivity = static_cast<float>(o.material.reflectivity);
  hit->bgr = o.material.bgr;
  if (o.texture && best_local.n.z() > 0.5) {
    const double a = o.texture->albedo(hit->p_local.x(), hit->p_local.y());
    if (a >= 0.0) {
      hit->reflectivity = static_cast<float>(kBlackPrintReflectivity +
                                             (kPaperReflectivity - kBlackPrintReflectivity) * a);
      const uint8_t g = static_cast<uint8_t>(std::lround(255.0 * a));
      hit->bgr = {{g, g, g}};
    }
  }
  if (!o.mud.empty()) {
    const Eigen::Vector3d& p = hit->p_local;
    const double phi = std::atan2(p.y(), p.x());
    for (const MudPatch& m : o.mud) {
      if (std::abs(p.z() - m.z_center) > m.z_half_width) continue;
      double dphi = std::remainder(phi - m.phi_center, 2.0 * M_PI);
      if (std::abs(dphi) > m.phi_half_width) continue;
      hit->reflectivity = static_cast<float>(o.material.reflectivity * m.reflectivity_factor);
      hit->bgr = kMudBgr;
      break;
    }
  }
  return true;
}

}  // namespace drill_pipe_pose::sim
