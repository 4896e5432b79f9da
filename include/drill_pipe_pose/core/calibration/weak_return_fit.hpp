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

/// The options were set from the sensor's figures before the fit first ran, except
/// min_departure (below).
struct WeakReturnFitOptions {
  /// [m] a placement counts when the prior law predicts at least this much bias between its
  /// brightest and its weakest samples. 5 mm: five times a Kinect v2's depth noise floor on a
  /// strong return (1.46 mm, the sensor check's), so the contrast stands above the noise.
  double min_contrast = 0.005;
  /// Placements with contrast the fit needs; fewer and the camera keeps the sensor's law (5: a
  /// jackknife over fewer says little about its own spread).
  int min_groups = 5;
  /// The fitted B is used only when its jackknife standard error is at most this share of it
  /// (or of the sensor's B, when smaller: a B of zero within its noise is a sensor without the
  /// bias, and is used as 0). 0.25: a camera's B known to a quarter, not a number the noise
  /// made.
  double max_relative_sigma = 0.25;
  /// A learned B replaces the sensor's only where it departs from it by more than this share
  /// (and by more than 3 of its standard errors): the sensor's B is itself known to about 18 %
  /// (the same fit on the real recording: 3.10e-9 +- 0.55e-9 against the sensor check's
  /// 4.035e-9, docs/results.md), and a camera that sees few placements near the law's floor
  /// learns B with more scatter than its jackknife says. Chosen with scripts/bench_calibration's
  /// seeds 72, 74, 75 and 76: the thesis lab's cam2, with 5 such placements, learned 0.86-1.11 of
  /// the true B (jackknife +-1.4-4.9 %) and moved its depth offset up to 1.6 mm off, while the
  /// rigs whose cameras see the board at 2-5 m learned it within 5 %.
  double min_departure = 0.2;
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
