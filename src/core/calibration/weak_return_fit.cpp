#include "drill_pipe_pose/core/calibration/weak_return_fit.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

namespace drill_pipe_pose::calibration {

namespace {

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

/// One placement's samples, demeaned: x~ = x - mean x, r~ = r - mean r.
struct Group {
  std::vector<double> x, r;
};

/// Weighted least squares through the origin of r~ on x~ over the groups, skipping `skip`.
double slope(const std::vector<Group>& groups, const std::vector<std::vector<double>>& w,
             size_t skip) {
  double sxy = 0, sxx = 0;
  for (size_t g = 0; g < groups.size(); ++g) {
    if (g == skip) continue;
    for (size_t i = 0; i < groups[g].x.size(); ++i) {
      sxy += w[g][i] * groups[g].x[i] * groups[g].r[i];
      sxx += w[g][i] * groups[g].x[i] * groups[g].x[i];
    }
  }
  return sxx > 0 ? sxy / sxx : 0.0;
}

}  // namespace

WeakReturnFit fitWeakReturnBias(const std::vector<WeakReturnSample>& samples,
                                const kinect_v2::AmplitudeModel& prior,
                                const WeakReturnFitOptions& options) {
  WeakReturnFit fit;
  fit.samples = static_cast<int>(samples.size());
  const auto h = [&prior](double a) { return kinect_v2::weakReturnShape(prior, a); };
  const double h_ref = h(prior.bias_min_amplitude);
  std::vector<double> amplitudes;
  std::map<int, std::vector<const WeakReturnSample*>> by_group;
  for (const WeakReturnSample& s : samples) {
    if (!(s.amplitude > 0) || !std::isfinite(s.residual)) continue;
    amplitudes.push_back(s.amplitude);
    by_group[s.group].push_back(&s);
  }
  fit.amplitude_lo = quantile(amplitudes, 0.05);
  fit.amplitude_hi = quantile(amplitudes, 0.95);
  // The placements whose samples span enough of the prior law to show it.
  std::vector<Group> groups;
  double best_contrast = 0.0;
  for (const auto& [id, members] : by_group) {
    std::vector<double> x;
    for (const WeakReturnSample* s : members) x.push_back(h(s->amplitude));
    const double contrast = prior.bias_coeff * (quantile(x, 0.9) - quantile(x, 0.1));
    best_contrast = std::max(best_contrast, contrast);
    if (contrast < options.min_contrast || members.size() < 4) continue;
    Group g;
    double mx = 0, mr = 0;
    for (size_t i = 0; i < members.size(); ++i) mx += x[i], mr += members[i]->residual;
    mx /= members.size(), mr /= members.size();
    for (size_t i = 0; i < members.size(); ++i) {
      g.x.push_back(x[i] - mx);
      g.r.push_back(members[i]->residual - mr);
    }
    groups.push_back(std::move(g));
  }
  fit.groups = static_cast<int>(groups.size());
  if (fit.groups < options.min_groups) {
    std::ostringstream why;
    why.precision(1);
    why << std::fixed << "the sensor's law kept: " << fit.groups << " placement(s) show its two prints "
        << options.min_contrast * 1e3 << " mm or more apart in predicted bias (at least "
        << options.min_groups << " needed; the best shows " << best_contrast * 1e3
        << " mm; hold the board nearer, where the white print returns strongly)";
    fit.note = why.str();
    return fit;
  }
  // Huber IRLS (k = 1.345 robust sigmas).
  std::vector<std::vector<double>> w(groups.size());
  for (size_t g = 0; g < groups.size(); ++g) w[g].assign(groups[g].x.size(), 1.0);
  double B = slope(groups, w, groups.size()), scale = 0.0;
  for (int iter = 0; iter < 10; ++iter) {
    std::vector<double> abs_e;
    for (const Group& g : groups)
      for (size_t i = 0; i < g.x.size(); ++i) abs_e.push_back(std::abs(g.r[i] - B * g.x[i]));
    scale = std::max(1.4826 * quantile(abs_e, 0.5), 1e-5);
    for (size_t g = 0; g < groups.size(); ++g)
      for (size_t i = 0; i < groups[g].x.size(); ++i) {
        const double e = std::abs(groups[g].r[i] - B * groups[g].x[i]) / scale;
        w[g][i] = e <= 1.345 ? 1.0 : 1.345 / e;
      }
    B = slope(groups, w, groups.size());
  }
  fit.coeff = B;
  fit.rms = scale;
  // Jackknife over placements.
  double mean = 0;
  std::vector<double> loo;
  for (size_t g = 0; g < groups.size(); ++g) loo.push_back(slope(groups, w, g)), mean += loo.back();
  mean /= loo.size();
  double ss = 0;
  for (double b : loo) ss += (b - mean) * (b - mean);
  fit.coeff_sigma = std::sqrt(ss * (loo.size() - 1) / loo.size());
  // The offset that goes with this B: the samples corrected by it, against the solved model.
  std::vector<double> shifted;
  for (const auto& [id, members] : by_group)
    for (const WeakReturnSample* s : members)
      shifted.push_back(s->residual - B * (h(s->amplitude) - h_ref));
  fit.offset_shift = quantile(shifted, 0.5);
  std::ostringstream why;
  const double scale_of_b = std::max(B, prior.bias_coeff);
  if (B < -2.0 * fit.coeff_sigma)
    why << "the sensor's law kept: the fit gives B = " << B << " +- " << fit.coeff_sigma
        << ", a bias that shrinks as the return weakens (a wrong amplitude image?)";
  else if (fit.coeff_sigma > options.max_relative_sigma * scale_of_b)
    why << "the sensor's law kept: B = " << B << " +- " << fit.coeff_sigma << " is known to "
        << std::lround(100 * fit.coeff_sigma / scale_of_b) << " % (at most "
        << std::lround(100 * options.max_relative_sigma) << " % needed)";
  const double departure = std::abs(B - prior.bias_coeff);
  if (why.str().empty() &&
      departure <= std::max(3.0 * fit.coeff_sigma, options.min_departure * prior.bias_coeff))
    why << "the sensor's law kept: B = " << B << " +- " << fit.coeff_sigma << " is "
        << std::lround(100.0 * B / prior.bias_coeff) << " % of the sensor's, within "
        << std::lround(100 * options.min_departure) << " % (or 3 of its errors) of it";
  if (why.str().empty() && B < 0) {  // zero within its noise: a sensor without the bias
    fit.coeff = 0.0;
    shifted.clear();
    for (const auto& [id, members] : by_group)
      for (const WeakReturnSample* s : members) shifted.push_back(s->residual);
    fit.offset_shift = quantile(shifted, 0.5);
  }
  fit.note = why.str();
  fit.fitted = fit.note.empty();
  return fit;
}

}  // namespace drill_pipe_pose::calibration
