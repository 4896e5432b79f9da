#include "drill_pipe_pose/sim/depth_effects.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "drill_pipe_pose/core/kinect_noise.hpp"
#include "drill_pipe_pose/sim/random.hpp"

namespace drill_pipe_pose::sim {

namespace {

/// Inverse standard-normal CDF (Acklam's rational approximation, |rel. error| < 1.2e-9).
double inverseNormalCdf(double p) {
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01, -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  const double pl = 0.02425;
  if (p < pl) {
    const double q = std::sqrt(-2 * std::log(p));
    return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  }
  if (p > 1 - pl) {
    const double q = std::sqrt(-2 * std::log(1 - p));
    return -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  }
  const double q = p - 0.5, r = q * q;
  return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
         (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
}

/// Lateral pixel shift tables: for sigma = kLateralMinPx + 0.1 k px, 256 entries of
/// round(N(0, sigma)), clamped to +-3 px.
constexpr int kLateralTables = 38;
constexpr float kLateralMinPx = 0.1f;
const std::vector<std::array<int8_t, 256>>& lateralTables() {
  static const std::vector<std::array<int8_t, 256>> tables = [] {
    std::vector<std::array<int8_t, 256>> t(kLateralTables);
    for (int k = 0; k < kLateralTables; ++k) {
      const double sigma = kLateralMinPx + 0.1 * k;
      for (int i = 0; i < 256; ++i) {
        const double x = sigma * inverseNormalCdf((i + 0.5) / 256.0);
        t[k][i] = static_cast<int8_t>(std::clamp<long>(std::lround(x), -3, 3));
      }
    }
    return t;
  }();
  return tables;
}

/// The 4-neighbour with a return whose depth differs most from z, around source pixel (su, sv).
struct EdgeNeighbour {
  float jump = 0.0f, z = 0.0f;
  size_t index = 0;
};
EdgeNeighbour largestJump(const float* Z, int W, int H, int su, int sv, float z) {
  EdgeNeighbour nb;
  const int nu[4] = {su - 1, su + 1, su, su};
  const int nv[4] = {sv, sv, sv - 1, sv + 1};
  for (int q = 0; q < 4; ++q) {
    if (nu[q] < 0 || nu[q] >= W || nv[q] < 0 || nv[q] >= H) continue;
    const size_t k = static_cast<size_t>(nv[q]) * W + nu[q];
    if (Z[k] > 0 && std::abs(Z[k] - z) > nb.jump) nb = {std::abs(Z[k] - z), Z[k], k};
  }
  return nb;
}

/// How far a mixed pixel's depth moves towards its neighbour's: the drawn share itself, or,
/// amplitude-weighted, the share is the neighbour's part of the pixel's footprint and the depth
/// read is the mean of the two returns weighted by their amplitudes (a_self, a_nb).
float mixedWeight(float share, bool amplitude_weighted, float a_self, float a_nb) {
  if (!amplitude_weighted) return share;
  const float self = (1.0f - share) * a_self, other = share * a_nb;
  return self + other > 0 ? other / (self + other) : 0.0f;
}

}  // namespace

const std::vector<float>& normalTable() {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    double sum2 = 0;
    for (int i = 0; i < 65536; ++i) {
      t[i] = static_cast<float>(inverseNormalCdf((i + 0.5) / 65536.0));
      sum2 += static_cast<double>(t[i]) * t[i];
    }
    const float scale = static_cast<float>(1.0 / std::sqrt(sum2 / 65536.0));  // exact variance
    for (float& v : t) v *= scale;
    return t;
  }();
  return table;
}

float incidenceTerm(float cos_theta, double max_incidence_rad) {
  return static_cast<float>(
      kinect_v2::incidenceFactor(static_cast<double>(cos_theta), max_incidence_rad));
}

namespace {

/// Weight w of the kernel [w, 1, w] whose output correlates by rho between neighbours:
/// rho = 2 w / (1 + 2 w^2), so w = (1 - sqrt(1 - 2 rho^2)) / (2 rho); rho is capped at 0.7.
float kernelWeight(double rho) {
  rho = std::clamp(rho, 0.0, 0.7);
  if (rho < 1e-6) return 0.0f;
  return static_cast<float>((1.0 - std::sqrt(1.0 - 2.0 * rho * rho)) / (2.0 * rho));
}

/// A width x height field of unit-variance normal numbers whose horizontal and vertical
/// neighbours correlate by rho (separable [w, 1, w] smoothing of white noise, renormalised).
void correlatedField(int W, int H, double rho, uint64_t seed, std::vector<float>* field) {
  const std::vector<float>& normal = normalTable();
  const size_t n = static_cast<size_t>(W) * H;
  std::vector<float> white(n), tmp(n);
  Rng rng(seed);
  for (size_t i = 0; i < n; i += 4) {
    const uint64_t b = rng.next();
    for (size_t k = 0; k < 4 && i + k < n; ++k) white[i + k] = normal[(b >> (16 * k)) & 0xFFFF];
  }
  const float w = kernelWeight(rho);
  const float norm = 1.0f / (1.0f + 2.0f * w * w);  // both passes: variance (1 + 2 w^2)^2
  for (int v = 0; v < H; ++v) {
    const float* r = &white[static_cast<size_t>(v) * W];
    float* o = &tmp[static_cast<size_t>(v) * W];
    for (int u = 0; u < W; ++u)
      o[u] = r[u] + w * (r[std::max(u - 1, 0)] + r[std::min(u + 1, W - 1)]);
  }
  field->resize(n);
  for (int v = 0; v < H; ++v) {
    const float* up = &tmp[static_cast<size_t>(std::max(v - 1, 0)) * W];
    const float* mid = &tmp[static_cast<size_t>(v) * W];
    const float* dn = &tmp[static_cast<size_t>(std::min(v + 1, H - 1)) * W];
    float* o = &(*field)[static_cast<size_t>(v) * W];
    for (int u = 0; u < W; ++u) o[u] = norm * (mid[u] + w * (up[u] + dn[u]));
  }
}

/// True when a 4-neighbour of pixel (u, v) is a return whose depth differs by more than jump,
/// or no return (the edge of a silhouette).
bool atDepthEdge(const float* Z, int W, int H, int u, int v, float jump) {
  const float z = Z[static_cast<size_t>(v) * W + u];
  const int nu[4] = {u - 1, u + 1, u, u};
  const int nv[4] = {v, v, v - 1, v + 1};
  for (int q = 0; q < 4; ++q) {
    if (nu[q] < 0 || nu[q] >= W || nv[q] < 0 || nv[q] >= H) continue;
    const float zn = Z[static_cast<size_t>(nv[q]) * W + nu[q]];
    if (!(zn > 0) || std::abs(zn - z) > jump) return true;
  }
  return false;
}

}  // namespace

float axialSigma(const SensorEffects& fx, float z, float g2, float amplitude) {
  float sigma = static_cast<float>(fx.axial_noise_scale) *
                std::max(0.1f, kinect_v2::axialSigmaMm(z, g2)) * 1e-3f;
  if (fx.amplitude_noise) {
    const float floor = static_cast<float>(fx.amplitude_noise_floor);
    const float weak = static_cast<float>(fx.amplitude_noise_coeff) / std::max(amplitude, 1e-6f);
    sigma = fx.amplitude_noise_additive ? std::sqrt(sigma * sigma + weak * weak)
                                        : std::max(sigma, std::sqrt(floor * floor + weak * weak));
  }
  return sigma;
}

float brightnessBias(const SensorEffects& fx, float amplitude) {
  if (!fx.brightness_bias) return 0.0f;
  kinect_v2::AmplitudeModel m;
  m.bias_coeff = fx.brightness_bias_coeff;
  m.bias_power = fx.brightness_bias_power;
  m.bias_min_amplitude = fx.brightness_bias_min_amplitude;
  return static_cast<float>(kinect_v2::weakReturnBias(m, amplitude, fx.brightness_bias_reference));
}

// One pass per pixel, the random numbers drawn in a fixed order (the rendered frames of a seed
// must not change): per pixel one draw for the lateral shift, flying pixel and dropout or
// saturation, and one more for the axial noise or the interference band; the correlated noise
// field, when on, comes from its own stream.
void applyDepthEffects(const SensorEffects& fx, const DepthSceneView& in, double depth_offset,
                       double depth_scale, uint64_t noise_seed, uint64_t interference_seed,
                       DepthImage* out, AmplitudeImage* amplitude) {
  const int W = in.width, H = in.height;
  if (amplitude) *amplitude = AmplitudeImage::allocate(W, H);
  const float dn_per_a = static_cast<float>(kinect_v2::kDnPerAmplitude);
  // The returned amplitude [1/m^2] of source pixel s seen at depth z.
  const auto amplitudeAt = [&](size_t s, float z) {
    const float rz = in.ray_z && fx.amplitude_by_range ? in.ray_z[s] : 1.0f;
    return in.reflectivity[s] * in.cos_incidence[s] * rz * rz / (z * z);
  };
  const DepthEncoding enc =
      fx.quantisation ? DepthEncoding::kU16Millimetres : DepthEncoding::kF32Metres;
  *out = DepthImage::allocate(W, H, enc);
  const std::vector<float>& normal = normalTable();
  const auto& lateral = lateralTables();
  Rng rng(noise_seed);

  // Interference burst of this frame (drawn always, applied when enabled).
  Rng irng(interference_seed);
  const bool burst = irng.chance(fx.interference_probability) && fx.interference;
  const int band_h = static_cast<int>(fx.interference_band_fraction * H);
  const int band_v0 = static_cast<int>(irng.uniform(0.0, std::max(1, H - band_h)));

  const float zmin = static_cast<float>(fx.min_range), zmax = static_cast<float>(fx.max_range);
  const float a_lo = static_cast<float>(fx.dropout_amplitude_low);
  const float a_hi = static_cast<float>(fx.dropout_amplitude_high);
  const float inv_ramp = 1.0f / std::max(a_hi - a_lo, 1e-9f);
  const float s_lo = static_cast<float>(fx.saturation_amplitude_low);
  const float inv_s_ramp =
      1.0f / std::max(static_cast<float>(fx.saturation_amplitude_high) - s_lo, 1e-9f);
  const float flying_p = static_cast<float>(fx.flying_probability);
  const float invalid_p = static_cast<float>(fx.edge_invalid_probability);
  const float w_lo = static_cast<float>(fx.flying_weight_min);
  const float w_span = static_cast<float>(fx.flying_weight_max - fx.flying_weight_min);
  const float lateral_px = static_cast<float>(fx.lateral_noise_px);
  const bool amplitude_weighted = fx.flying_amplitude_weighted;
  const float jump = static_cast<float>(fx.flying_jump);
  const float offset = static_cast<float>(depth_offset);
  const float scale = static_cast<float>(depth_scale);
  const bool lateral_on = fx.lateral_noise, flying_on = fx.flying_pixels;
  const bool dropout_on = fx.dropout, axial_on = fx.axial_noise;
  const bool noisy = lateral_on || flying_on || dropout_on || axial_on || burst ||
                     fx.saturation || fx.brightness_bias;
  const float* Z = in.z;
  std::vector<float> field;
  if (axial_on && fx.correlated_noise)
    correlatedField(W, H, fx.noise_correlation, noise_seed ^ 0x5DEECE66DULL, &field);

  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      if (!noisy) {
        const float z = Z[i];
        if (z > 0 && z >= zmin && z <= zmax) {
          out->setDepth(u, v, z * scale + offset);
          if (amplitude) amplitude->set(u, v, amplitudeAt(i, z) * dn_per_a);
        }
        continue;
      }
      const uint64_t bits = rng.next();
      size_t s = i;
      int su = u, sv = v;
      if (lateral_on && (!fx.lateral_noise_at_edges_only ||
                         (Z[i] > 0 && atDepthEdge(Z, W, H, u, v, jump)))) {
        const float g = std::sqrt(in.g2[i]);
        const float sigma_px = lateral_px + 0.035f * g;  // Fankhauser et al. 2015, lateral
        const int k = std::clamp(static_cast<int>((sigma_px - kLateralMinPx) * 10.0f + 1e-3f), 0,
                                 kLateralTables - 1);
        su = std::clamp(u + lateral[k][bits & 0xFF], 0, W - 1);
        sv = std::clamp(v + lateral[k][(bits >> 8) & 0xFF], 0, H - 1);
        s = static_cast<size_t>(sv) * W + su;
      }
      float z = Z[s];
      if (!(z > 0)) continue;
      if (flying_on) {
        const EdgeNeighbour nb = largestJump(Z, W, H, su, sv, z);
        if (nb.jump > jump) {
          // One draw decides: invalid below invalid_p, mixed in the next flying_p.
          const float u_edge = ((bits >> 16) & 0xFFFF) * (1.0f / 65536.0f);
          if (u_edge < invalid_p) continue;
          if (u_edge < invalid_p + flying_p) {
            const float share = w_lo + w_span * (((bits >> 48) & 0xFFFF) * (1.0f / 65536.0f));
            z += mixedWeight(share, amplitude_weighted, amplitudeAt(s, z),
                             amplitudeAt(nb.index, nb.z)) *
                 (nb.z - z);
          }
        }
      }
      if (z < zmin || z > zmax) continue;
      const float a = amplitudeAt(s, z);
      if (amplitude) amplitude->set(u, v, a * dn_per_a);
      const float u01 = ((bits >> 32) & 0xFFFF) * (1.0f / 65536.0f);  // dropout or saturation
      if (dropout_on) {
        const float p_drop = (a_hi - a) * inv_ramp;
        if (p_drop > 0 && u01 < p_drop) continue;
      }
      if (fx.saturation && a > s_lo && u01 < (a - s_lo) * inv_s_ramp) continue;
      const bool in_band = burst && v >= band_v0 && v < band_v0 + band_h;
      if (axial_on || in_band) {
        const uint64_t nb = rng.next();
        if (axial_on)
          z += axialSigma(fx, z, in.g2[s], a) * (field.empty() ? normal[nb & 0xFFFF] : field[i]);
        if (in_band) {
          z += static_cast<float>(fx.interference_sigma) * normal[(nb >> 16) & 0xFFFF];
          if (((nb >> 32) & 0xFFFF) * (1.0f / 65536.0f) < fx.interference_dropout) continue;
        }
      }
      z += brightnessBias(fx, a);
      z = z * scale + offset;
      if (z > 0) out->setDepth(u, v, z);
    }
  }
}

}  // namespace drill_pipe_pose::sim
