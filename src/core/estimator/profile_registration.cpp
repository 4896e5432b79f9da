// The roll-free (5-DoF) profile registration: residuals, Jacobian, cost, the 1-DoF search along
// the axis, IRLS refinement with projective correspondences, hypotheses, and the radius check.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/kinect_noise.hpp"
#include "drill_pipe_pose/core/quadratic.hpp"
#include "drill_pipe_pose/core/estimator/profile_registration.hpp"
#include "drill_pipe_pose/core/estimator/basis.hpp"
#include "drill_pipe_pose/core/estimator/cutout.hpp"

namespace drill_pipe_pose {

namespace {
/// The Kinect v2's fitted amplitude effects (the simulator draws from the same definition).
const kinect_v2::AmplitudeModel kAmplitude;
}  // namespace

double profileResidual(const ProfileModel& model, const Eigen::Vector3d& p,
                       const Eigen::Vector3d& origin, const Eigen::Vector3d& z,
                       const Eigen::Vector3d& e1, const Eigen::Vector3d& e2,
                       const Eigen::Vector3f* eye, Eigen::Vector2d* grad, bool* ray_hit) {
  if (ray_hit) *ray_hit = false;
  const Eigen::Vector3d q = p - origin;
  const double zc = q.dot(z), rc = (q - zc * z).norm();
  if (eye) {
    const Eigen::Vector3d ray = p - eye->cast<double>();
    const double range = ray.norm();
    if (range > 0.1) {
      const Eigen::Vector3d dw = ray / range;
      const Eigen::Vector3d qe(q.dot(e1), q.dot(e2), zc), de(dw.dot(e1), dw.dot(e2), dw.dot(z));
      double s;
      Eigen::Vector2d zr, n;
      if (model.rayHit(qe, de, -(range - 0.05), &s, &zr, &n)) {
        if (grad) *grad = n;
        if (ray_hit) *ray_hit = true;
        // Well behind the visible surface (the model hides the point): the distance along the
        // ray; otherwise the signed distance to the tangent plane at the hit.
        if (s < -0.05) return s;
        return n.dot(Eigen::Vector2d(zc, rc) - zr);
      }
    }
  }
  return model.distance(zc, rc, grad);
}

Eigen::Matrix<double, 5, 1> profileJacobian(const Eigen::Vector3d& q, double zc,
                                            const Eigen::Vector3d& u, const Eigen::Vector3d& e1,
                                            const Eigen::Vector3d& e2,
                                            const Eigen::Vector2d& grad) {
  Eigen::Matrix<double, 5, 1> J;
  J << -grad.y() * u.dot(e1), -grad.y() * u.dot(e2), -grad.x(),
      grad.x() * q.dot(e1) - grad.y() * zc * u.dot(e1),
      grad.x() * q.dot(e2) - grad.y() * zc * u.dot(e2);
  return J;
}

RadiusCheck radiusOffset(const ProfileModel& model, double od_radius,
                         const Eigen::Vector3d& origin, const Eigen::Vector3d& z_axis,
                         const std::vector<Eigen::Vector3f>& points,
                         const std::vector<Eigen::Vector3f>& eyes,
                         const std::vector<uint8_t>& inlier_mask, double z_max) {
  RadiusCheck out;
  const Eigen::Vector3d z = z_axis.normalized();
  Eigen::Vector3d e1, e2;
  orthoBasis(z, &e1, &e2);
  // Normal equations of (pose, radius): [P G; G^T D] [dpose; dr] = [Je; ge], the pose then
  // eliminated (Schur complement): the radius that the points imply whatever the pose.
  Eigen::Matrix<double, 5, 5> P = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> Je = Eigen::Matrix<double, 5, 1>::Zero(),
                              G = Eigen::Matrix<double, 5, 1>::Zero();
  double D = 0, ge = 0, ss = 0;
  double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo;
  size_t n = 0;
  const size_t m = std::min({points.size(), eyes.size(), inlier_mask.size()});
  for (size_t i = 0; i < m; ++i) {
    if (!inlier_mask[i]) continue;
    const Eigen::Vector3d p = points[i].cast<double>();
    Eigen::Vector2d gr;
    bool hit = false;
    const double e = profileResidual(model, p, origin, z, e1, e2, &eyes[i], &gr, &hit);
    if (!hit) continue;
    const Eigen::Vector3d q = p - origin;
    const double zc = q.dot(z);
    const Eigen::Vector3d qp = q - zc * z;
    const double rc = qp.norm();
    if (rc < 1e-9) continue;
    const Eigen::Matrix<double, 5, 1> J = profileJacobian(q, zc, qp / rc, e1, e2, gr);
    P += J * J.transpose();
    Je += J * e;
    ss += e * e;
    ++n;
    // On the tool joint's OD (a radial normal, the surface at the OD): a larger OD moves the
    // surface outward, toward the point.
    const double hit_r = rc - e * gr.y();
    if (std::abs(gr.x()) > 0.1 || std::abs(hit_r - od_radius) > 0.003) continue;
    const double hit_z = zc - e * gr.x();
    if (hit_z > z_max) continue;
    const double jr = -gr.y();
    G += J * jr;
    D += jr * jr;
    ge += jr * e;
    ++out.points;
    z_lo = std::min(z_lo, hit_z);
    z_hi = std::max(z_hi, hit_z);
  }
  if (n < 10 || out.points < 10) return out;
  out.extent = z_hi - z_lo;
  Eigen::Matrix<double, 5, 5> Pd = P;
  Pd.diagonal().array() += 1e-9 + 1e-9 * P.diagonal().array();
  const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(Pd);
  const Eigen::Matrix<double, 5, 1> PinvG = ldlt.solve(G);
  const double info = D - G.dot(PinvG);
  if (!(info > 1e-9 * D)) return out;
  out.ok = true;
  // e ~ J dpose + jr dr: dr solves the reduced system; its sign makes a thinner joint negative.
  out.offset = -(ge - PinvG.dot(Je)) / info;
  out.std = std::sqrt(ss / static_cast<double>(n) / info);
  return out;
}

double profileCost(const std::vector<Eigen::Vector3f>& points, const ProfileModel& model,
                   const Eigen::Vector3d& origin, const Eigen::Vector3d& z, double truncation,
                   const std::vector<Eigen::Vector3f>* eyes) {
  if (points.empty()) return 0.0;
  double cost = 0;
  const double T2 = truncation * truncation;
  Eigen::Vector3d e1, e2;
  orthoBasis(z, &e1, &e2);
  for (size_t i = 0; i < points.size(); ++i) {
    const double d = profileResidual(model, points[i].cast<double>(), origin, z, e1, e2,
                                     eyes ? &(*eyes)[i] : nullptr);
    cost += std::min(d * d, T2);
  }
  return cost / points.size();
}

namespace {

/// 1-DoF search along the axis for the shoulder, for one direction (sign) of the axis. Returns
/// the origin's coordinate s along sign * direction from axis.point.
double axialSearch(const std::vector<double>& ts, const std::vector<double>& rs, int sign,
                   const ProfileModel& model, const EstimatorConfig::ProfileFit& config,
                   double* best_cost) {
  const double T2 = config.truncation * config.truncation;
  const auto [t_lo_it, t_hi_it] = std::minmax_element(ts.begin(), ts.end());
  const double t_lo = sign * *t_lo_it, t_hi = sign * *t_hi_it;
  auto searchCost = [&](double s) {
    double cost = 0;
    for (size_t i = 0; i < ts.size(); ++i) {
      const double d = model.coarseDistance(sign * ts[i] - s, rs[i]);
      cost += std::min(d * d, T2);
    }
    return cost;
  };
  // Coarse (2.5 steps) over the whole range, then fine around the best.
  // End-frame z of a point = sign * t - s.
  const double coarse = 2.5 * config.search_step;
  const double lo = std::min(t_lo, t_hi) - model.zMax() - 0.05;
  const double hi = std::max(t_lo, t_hi) - model.zMin() + 0.05;
  double best = std::numeric_limits<double>::infinity(), best_s = lo;
  for (double s = lo; s <= hi; s += coarse) {
    const double cost = searchCost(s);
    if (cost < best) {
      best = cost;
      best_s = s;
    }
  }
  const double s0 = best_s;
  for (double s = s0 - coarse; s <= s0 + coarse + 1e-9; s += config.search_step) {
    const double cost = searchCost(s);
    if (cost < best) {
      best = cost;
      best_s = s;
    }
  }
  *best_cost = best;
  return best_s;
}

/// The radial component of the closest model surface's normal above which a pixel whose ray
/// misses the model counts as one of the joint's side silhouette: within 25 deg of radial, the
/// cylinders and the 18 deg elevator taper, not the end face, the shoulders or the bore.
constexpr double kSilhouetteNormal = 0.9;

/// The returned amplitude of point p (seen from eye) at the model's surface (normal from the
/// profile gradient gr at the fit's axis o, z), for the assumed config.reflectivity: takes its
/// weak-return bias (along the ray, farther) out of the residual *e and returns its noise, which
/// bounds the point's sigma below (0 when the geometry is degenerate).
double correctWeakReturn(const Eigen::Vector3d& p, const Eigen::Vector3d& eye,
                         const Eigen::Vector3d& o, const Eigen::Vector3d& z,
                         const Eigen::Vector2d& gr, const EstimatorConfig::ProfileFit& config,
                         double* e) {
  const Eigen::Vector3d q = p - o;
  const Eigen::Vector3d radial = q - q.dot(z) * z;
  const Eigen::Vector3d ray = p - eye;
  const double range = ray.norm(), rn = radial.norm();
  if (range <= 0.1 || rn <= 1e-9) return 0.0;
  const Eigen::Vector3d n3 = (gr.x() * z + gr.y() * (radial / rn)).normalized();
  const double n_dot_ray = n3.dot(ray) / range;
  const double a = config.reflectivity * std::abs(n_dot_ray) / (range * range);
  *e -= kinect_v2::weakReturnBias(kAmplitude, a, config.bias_reference) * n_dot_ray;
  return kinect_v2::amplitudeSigma(kAmplitude, a);
}

/// One IRLS pass's sums over the points at pose (o, z): the normal equations (H, g), their part
/// that counts for the covariance (H_cov, chi2, n_used: silhouette points steer but do not
/// count) and the statistics over every point (cost, ss and inl over the inliers).
struct IrlsPass {
  Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 5> H_cov = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
  double chi2 = 0, cost = 0, ss = 0;
  size_t n_used = 0, inl = 0;
};

/// The pass at (o, z) over pts; writes each point's inlier flag into *inlier_mask. `silhouettes`:
/// whether silhouette points (rays that miss the model) steer this pass.
IrlsPass irlsPass(const std::vector<Eigen::Vector3d>& pts, const std::vector<float>& sigmas,
                  const Eigen::Vector3d& o, const Eigen::Vector3d& z, const ProfileModel& model,
                  const EstimatorConfig::ProfileFit& config, double z_trust, bool silhouettes,
                  const std::vector<Eigen::Vector3f>* eyes, std::vector<uint8_t>* inlier_mask) {
  const double T = config.truncation, T2 = T * T;
  Eigen::Vector3d e1, e2;
  orthoBasis(z, &e1, &e2);
  IrlsPass ps;
  for (size_t i = 0; i < pts.size(); ++i) {
    Eigen::Vector2d gr;
    bool hit = false;
    double e =
        profileResidual(model, pts[i], o, z, e1, e2, eyes ? &(*eyes)[i] : nullptr, &gr, &hit);
    const double amp_sigma =
        hit && config.reflectivity > 0
            ? correctWeakReturn(pts[i], (*eyes)[i].cast<double>(), o, z, gr, config, &e)
            : 0.0;
    const double d = std::abs(e);
    ps.cost += std::min(d * d, T2);
    const double gate = std::min(T, std::max(0.01, 3.0 * sigmas[i]));
    (*inlier_mask)[i] = d < gate;
    if (d < gate) {
      ps.ss += d * d;
      ++ps.inl;
    }
    const Eigen::Vector3d q = pts[i] - o;
    const double zc = q.dot(z);
    // Beyond the trusted tong (worn joints are shorter): the radius still fixes the axis
    // (lateral and tilt), but not the position along it.
    const bool axial_info = zc >= z_trust;
    const Eigen::Vector3d qp = q - zc * z;
    const double rc = qp.norm();
    if (rc < 1e-9) continue;
    if (d > T) continue;
    // A ray that misses the model: a pixel beyond the joint's silhouette as the model sees it.
    // Where its closest model surface faces away from the axis (the joint's sides,
    // kSilhouetteNormal), it is a side pixel that lateral noise (the depth of a neighbouring
    // pixel) moved outward: it counts at that distance, as its twin moved inward (whose ray
    // meets the model) does. Leaving these out biased the simulator's thesis_angled fits
    // (0.75 deg and 5.3 mm without them, 0.64 deg and 4.9 mm with them; a synthetic model of
    // lateral noise alone shows a smaller bias, so that mechanism is not the whole story).
    // Others (beyond the end face or a shoulder, into the bore) do not steer the fit, nor do
    // any while the fit explains few of its points (dark steel: its silhouette's mixed
    // pixels would pull it).
    const bool silhouette = eyes && !hit;
    if (silhouette && !(silhouettes && gr.y() >= kSilhouetteNormal)) continue;
    double sigma = std::max<double>(sigmas[i], amp_sigma);
    if (config.incidence_noise > 0 && eyes) {
      // The depth noise's growth toward grazing incidence, at the model's normal there.
      const Eigen::Vector3d ray = pts[i] - (*eyes)[i].cast<double>();
      const double range = ray.norm();
      const Eigen::Vector3d n3 = gr.x() * z + gr.y() * (qp / rc);
      sigma += incidenceSigma(config.incidence_noise, range,
                              std::abs(n3.dot(ray)) / (range * n3.norm()));
    }
    const double k = config.huber * sigma;
    const double w = (d <= k ? 1.0 : k / d) / (sigma * sigma);
    Eigen::Matrix<double, 5, 1> J = profileJacobian(q, zc, qp / rc, e1, e2, gr);
    // No pull along the axis from the untrusted part.
    if (!axial_info) J(2) = 0.0;
    ps.H += w * J * J.transpose();
    ps.g += w * J * e;
    // A silhouette point's closest-point distance is an approximation: it steers the fit but
    // adds nothing to the reported certainty.
    if (silhouette) continue;
    ps.H_cov += w * J * J.transpose();
    ps.chi2 += e * e / (sigma * sigma);
    ++ps.n_used;
  }
  return ps;
}

/// The damped Gauss-Newton step of a pass (axial part zero when lock_axial), applied to (o, z)
/// with its length limited (robustness far from the optimum). False when the step is not
/// finite; *step_t and *step_r: its translation [m] and rotation [rad] before the limit.
bool applyIrlsStep(const IrlsPass& ps, bool lock_axial, Eigen::Vector3d* o, Eigen::Vector3d* z,
                   double* step_t, double* step_r) {
  Eigen::Vector3d e1, e2;
  orthoBasis(*z, &e1, &e2);
  Eigen::Matrix<double, 5, 5> Hd = ps.H;
  Hd.diagonal().array() += 1e-6 * Hd.diagonal().array() + 1e-3;
  Eigen::Matrix<double, 5, 1> gd = ps.g;
  if (lock_axial) {  // solve for the other four
    Hd.row(2).setZero();
    Hd.col(2).setZero();
    Hd(2, 2) = 1.0;
    gd(2) = 0.0;
  }
  const Eigen::Matrix<double, 5, 1> delta = -Hd.ldlt().solve(gd);
  if (!delta.allFinite()) return false;
  *step_t = delta.head<3>().norm();
  *step_r = delta.tail<2>().norm();
  const double scale =
      std::min({1.0, 0.05 / std::max(*step_t, 1e-12), 0.1 / std::max(*step_r, 1e-12)});
  *o += scale * (delta[0] * e1 + delta[1] * e2 + delta[2] * *z);
  *z = (*z + scale * (delta[3] * e1 + delta[4] * e2)).normalized();
  return true;
}
}  // namespace

ProfileFitResult refineProfile(const std::vector<Eigen::Vector3f>& points,
                               const std::vector<float>& sigmas, const Eigen::Vector3d& origin,
                               const Eigen::Vector3d& z_axis, const ProfileModel& model,
                               const EstimatorConfig::ProfileFit& config, int iterations,
                               bool lock_axial, const std::vector<Eigen::Vector3f>* eyes) {
  ProfileFitResult res;
  res.label = model.label();
  if (points.size() < 10 || sigmas.size() != points.size()) return res;
  Eigen::Vector3d o = origin, z = z_axis.normalized();
  // IRLS Gauss-Newton on the 5 DoF: o += a1 e1 + a2 e2 + a3 z, z += b1 e1 + b2 e2.
  const double z_trust = model.trustedMinZ(config.wear_margin);
  std::vector<Eigen::Vector3d> pts(points.size());
  for (size_t i = 0; i < points.size(); ++i) pts[i] = points[i].cast<double>();
  // Statistics over all points at the pass's pose (the last pass's are the result's).
  res.inlier_mask.assign(points.size(), 0);
  IrlsPass ps;
  // Silhouette points steer a pass only when the previous one explained at least
  // config.silhouette_min_inlier_fraction of the points.
  bool silhouettes = false, next_silhouettes = false;
  for (int it = 0; it < iterations + 1; ++it) {
    silhouettes = next_silhouettes;
    ps = irlsPass(pts, sigmas, o, z, model, config, z_trust, silhouettes, eyes,
                  &res.inlier_mask);
    next_silhouettes = config.silhouette_points &&
                       static_cast<double>(ps.inl) >=
                           config.silhouette_min_inlier_fraction * static_cast<double>(pts.size());
    res.origin = o;
    res.z = z;
    if (it == iterations || ps.n_used < 10) break;
    double step_t = 0, step_r = 0;
    if (!applyIrlsStep(ps, lock_axial, &o, &z, &step_t, &step_r)) break;
    // Converged: steps far below the noise (0.1 mm, 0.1 mrad).
    if (step_t < 1e-4 && step_r < 1e-4 && next_silhouettes == silhouettes) {
      it = iterations - 1;  // one more pass to evaluate H at the optimum
    }
  }
  if (ps.n_used < 10) return res;
  // The result: the pose of the last pass (H and the statistics were evaluated there).
  o = res.origin;
  z = res.z;
  res.cost = ps.cost / pts.size();
  res.inliers = ps.inl;
  res.rms = ps.inl ? std::sqrt(ps.ss / ps.inl) : 0.0;
  Eigen::Vector3d e1, e2;
  orthoBasis(z, &e1, &e2);
  res.basis.col(0) = e1;
  res.basis.col(1) = e2;
  res.basis.col(2) = z;
  const double dof = std::max<double>(1.0, static_cast<double>(ps.n_used) - 5.0);
  const double s2 = std::max(1.0, ps.chi2 / dof);
  Eigen::Matrix<double, 5, 5> Hr = ps.H_cov;
  Hr.diagonal().array() += 1e-9;
  res.covariance = s2 * Hr.inverse();
  res.ok = res.covariance.allFinite() && o.allFinite() && z.allFinite();
  return res;
}

std::array<ProfileFitResult, 2> fitProfileHypotheses(const std::vector<Eigen::Vector3f>& points,
                                                     const std::vector<float>& sigmas,
                                                     const AxisLine& axis,
                                                     const ProfileModel& model,
                                                     const EstimatorConfig::ProfileFit& config,
                                                     const ProfileModel* search_model,
                                                     const std::vector<Eigen::Vector3f>* eyes) {
  std::array<ProfileFitResult, 2> hyp;
  const ProfileModel& sm = search_model ? *search_model : model;
  hyp[0].label = hyp[1].label = model.label();
  if (points.size() < 10 || sigmas.size() != points.size()) return hyp;
  const Eigen::Vector3d d0 = axis.direction.normalized();
  const size_t stride = std::max<size_t>(1, points.size() / config.search_points);
  std::vector<double> ts, rs;
  for (size_t i = 0; i < points.size(); i += stride) {
    const Eigen::Vector3d q = points[i].cast<double>() - axis.point;
    const double t = q.dot(d0);
    ts.push_back(t);
    rs.push_back((q - t * d0).norm());
  }
  for (int k = 0; k < 2; ++k) {
    const int sign = k == 0 ? 1 : -1;
    double c = 0;
    const double s = axialSearch(ts, rs, sign, sm, config, &c);
    const Eigen::Vector3d z = sign * d0;
    hyp[k] = refineProfile(points, sigmas, axis.point + s * z, z, model, config,
                           config.hypothesis_iterations, false, eyes);
  }
  return hyp;
}

ProfileFitResult fitProfile(const std::vector<Eigen::Vector3f>& points,
                            const std::vector<float>& sigmas, const AxisLine& axis,
                            const ProfileModel& model, const EstimatorConfig::ProfileFit& config) {
  const auto hyp = fitProfileHypotheses(points, sigmas, axis, model, config);
  if (hyp[0].ok && (!hyp[1].ok || hyp[0].cost <= hyp[1].cost)) return hyp[0];
  return hyp[1];
}

}  // namespace drill_pipe_pose
