#pragma once
// The Kinect v2 axial depth-noise model (Fankhauser et al. 2015, "Kinect v2 for mobile robot
// navigation: evaluation and modeling"), the one definition shared by the simulator (which draws
// noise from it) and the estimator (which weighs points by it):
//   sigma_z [mm] = 1.5 - 0.5 z + 0.3 z^2 + 0.1 z^1.5 g^2,   g = theta / (pi/2 - theta),
// z the depth [m], theta the angle between the camera ray and the surface normal, clamped to a
// maximum incidence (84 deg by default) where the model's last term would blow up.
// Templated on the scalar so that the simulator's float path stays float.

#include <algorithm>
#include <cmath>

namespace drill_pipe_pose::kinect_v2 {

/// [rad] the largest incidence angle the model is evaluated at.
constexpr double kMaxIncidence = 84.0 * M_PI / 180.0;

/// The model's incidence factor g^2 = (theta / (pi/2 - theta))^2 for a surface seen at the
/// cosine of incidence `cos_incidence` (clamped to [0, 1]), theta at most max_incidence [rad].
inline double incidenceFactor(double cos_incidence, double max_incidence = kMaxIncidence) {
  const double theta = std::min(std::acos(std::clamp(cos_incidence, 0.0, 1.0)), max_incidence);
  const double g = theta / (M_PI_2 - theta);
  return g * g;
}

/// Axial noise standard deviation [mm] at depth z [m] with incidence factor g2
/// (incidenceFactor; 0 head-on). No floor: callers clamp as they need.
template <typename T>
T axialSigmaMm(T z, T g2) {
  return T(1.5) - T(0.5) * z + T(0.3) * z * z + T(0.1) * z * std::sqrt(z) * g2;
}

/// The incidence term alone [mm] with its coefficient (0.1 in the model): coefficient z^1.5 g^2.
inline double incidenceSigmaMm(double coefficient, double z, double g2) {
  return coefficient * z * std::sqrt(z) * g2;
}

}  // namespace drill_pipe_pose::kinect_v2
