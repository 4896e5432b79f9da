#pragma once
// A camera's own weak-return bias law, learned from the calibration target's two prints.
//
// A Kinect v2 reads a weak return farther than a strong one: bias(a) = B max(a, a_min)^-p, a the
// returned amplitude [1/m^2] (core/kinect_noise.hpp; B, p and a_min fitted on one real sensor).
// Devices differ in B. At every placement the target shows two amplitude levels, its white and
// its black print, at the same plane: the depth difference between them, against their
// amplitudes, gives the camera's B with p and a_min kept from the sensor fit.
//
// Each placement (a group) gets its own intercept, so the fit uses only the contrast inside a
// placement: an error in the placement's solved plane moves both prints alike and cancels. The
// fit is Huber-robust (the dark print's depth scatters by centimetres where it is weak), and its
// standard error is a jackknife over placements (samples of one placement share its plane's
// error, so they do not count as independent).

#include <string>
#include <vector>

#include "drill_pipe_pose/core/kinect_noise.hpp"

namespace drill_pipe_pose::calibration {

struct WeakReturnSample {
  int group = 0;          ///< the placement it was seen at (one camera's frames of it share a plane)
  double amplitude = 0;   ///< [1/m^2]
  double residual = 0;    ///< [m] depth as read - the solved model's depth (scale z + offset)
};

/// The options were set from the sensor's figures before the fit first ran; min_contrast was
/// then raised once (below).
struct WeakReturnFitOptions {
  /// [m] a placement counts when the prior law predicts at least this much bias between its
  /// brightest and its weakest samples. 10 mm: about the weak print's own depth noise (the fit's
  /// robust rms in the thesis lab, 9-10 mm). Chosen on scripts/bench_calibration's seeds 72, 74
  /// and 75: at 5 mm (five times the strong-return noise floor, the first setting) cam2 of the
  /// thesis lab, with 6 such placements, all near the law's floor, learned 0.86-1.11 of the true
  /// B while its jackknife said +-1.4-4.9 %, and its depth offset moved up to 1.4 mm off. The
  /// other rigs' placements show 20-28 mm and are not affected.
  double min_contrast = 0.010;
  /// Placements with contrast the fit needs; fewer and the camera keeps the sensor's law (5: a
  /// jackknife over fewer says little about its own spread).
  int min_groups = 5;
  /// The fitted B is used only when its jackknife standard error is at most this share of it
  /// (or of the sensor's B, when smaller: a B of zero within its noise is a sensor without the
  /// bias, and is used as 0). 0.25: a camera's B known to a quarter, not a number the noise
  /// made.
  double max_relative_sigma = 0.25;
};

struct WeakReturnFit {
  bool fitted = false;     ///< B fitted and trustworthy (else `note` says why)
  double coeff = 0.0;      ///< [m (1/m^2)^p] B
  double coeff_sigma = 0.0;
  /// [m] what the camera's depth offset gains when its depth is corrected with this B (relative
  /// to the bias at a_min, the estimator's default reference) instead of the solve's model: the
  /// median of residual - B (max(a, a_min)^-p - a_min^-p) over the inlier samples.
  double offset_shift = 0.0;
  int samples = 0;         ///< samples given
  int groups = 0;          ///< placements with contrast
  double amplitude_lo = 0, amplitude_hi = 0;  ///< [1/m^2] 5th and 95th percentile of the samples
  double rms = 0.0;        ///< [m] robust rms of the fit's residuals
  std::string note;        ///< why not fitted (empty when fitted)
};

/// Fits B of `prior`'s law (its p and a_min kept) to `samples`.
WeakReturnFit fitWeakReturnBias(const std::vector<WeakReturnSample>& samples,
                                const kinect_v2::AmplitudeModel& prior,
                                const WeakReturnFitOptions& options = {});

}  // namespace drill_pipe_pose::calibration
