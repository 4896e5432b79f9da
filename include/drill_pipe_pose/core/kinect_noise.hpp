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

/// The effects of the returned amplitude a = reflectivity cos(theta) / z^2 [1/m^2], fitted to a
/// real Kinect v2 imaging a chessboard at 0.5-1.5 m (`scripts/sensor_check DATA --fit`,
/// docs/sensor_check.md; white paper = reflectivity 0.8 ties a to the IR image's numbers):
/// the one definition the simulator draws from and the estimator predicts with.
struct AmplitudeModel {
  double noise_floor = 0.00146;        ///< [m] the spread of strong returns
  double noise_coeff = 1.397e-4;       ///< [m m^-2] weak-return noise C / a
  double bias_coeff = 4.035e-9;        ///< [m (m^-2)^p] weak-return bias B a^-p (farther)
  double bias_power = 4.0;             ///< p
  double bias_min_amplitude = 0.0194;  ///< [1/m^2] the bias is held below this (the data's edge)
};

/// [DN per 1/m^2] the Kinect v2 IR image's digital numbers per unit of amplitude a: the real
/// recording's bright squares (white paper, reflectivity 0.8) read 32208 DN x cos^1.71 / z^2
/// (`scripts/sensor_check DATA --fit`, docs/sensor_check.md), so DN = 40260 a. The simulator
/// renders its IR image with it; the estimator reads amplitudes back with it
/// (noise/amplitude_scale, another driver's scale there).
constexpr double kDnPerAmplitude = 40260.0;

/// Noise [m] of a return of amplitude a: sqrt(floor^2 + (C / a)^2).
inline double amplitudeSigma(const AmplitudeModel& m, double a) {
  const double weak = m.noise_coeff / std::max(a, 1e-6);
  return std::sqrt(m.noise_floor * m.noise_floor + weak * weak);
}

/// The weak-return bias law's shape, max(a, a_min)^-p: the bias of amplitude a per unit of B.
inline double weakReturnShape(const AmplitudeModel& m, double a) {
  const double x = std::max(a, m.bias_min_amplitude);
  if (m.bias_power == 4.0) {  // the fitted p, without std::pow (called per point and iteration)
    const double x2 = x * x;
    return 1.0 / (x2 * x2);
  }
  return std::pow(x, -m.bias_power);
}

/// Depth bias [m] (+ = farther) of a return of amplitude a, less the bias at `reference` (what a
/// depth calibration on a target of that amplitude removed; 0: nothing removed):
/// B (max(a, a_min)^-p - max(reference, a_min)^-p).
inline double weakReturnBias(const AmplitudeModel& m, double a, double reference) {
  const double ref = reference > 0 ? weakReturnShape(m, reference) : 0.0;
  return m.bias_coeff * (weakReturnShape(m, a) - ref);
}

}  // namespace drill_pipe_pose::kinect_v2
