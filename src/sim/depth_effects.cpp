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

/// Lateral pixel shift tables: for sigma = 0.8 + 0.1 k px, 256 entries of round(N(0, sigma)),
/// clamped to +-3 px.
constexpr int kLateralTables = 30;
const std::vector<std::array<int8_t, 256>>& lateralTables() {
  static const std::vector<std::array<int8_t, 256>> tables = [] {
    std::vector<std::array<int8_t, 256>> t(kLateralTables);
    for (int k = 0; k < kLateralTables; ++k) {
      const double sigma = 0.8 + 0.1 * k;
      for (int i = 0; i < 256; ++i) {
        const double x = sigma * inverseNormalCdf((i + 0.5) / 256.0);
        t[k][i] = static_cast<int8_t>(std::clamp<long>(std::lround(x), -3, 3));
      }
    }
    return t;
  }();
  return tables;
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

// One pass per pixel, the random numbers drawn in a fixed order (the rendered frames of a seed
// must not change): per pixel one draw for the lateral shift, flying pixel and dropout, and one
// more for the axial noise or the interference band.
void applyDepthEffects(const SensorEffects& fx, const DepthSceneView& in, double depth_offset,
                       uint64_t noise_seed, uint64_t interference_seed, DepthImage* out) {
  const int W = in.width, H = in.height;
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
  const float flying_p = static_cast<float>(fx.flying_probability);
  const float jump = static_cast<float>(fx.flying_jump);
  const float offset = static_cast<float>(depth_offset);
  const float axial_scale = static_cast<float>(fx.axial_noise_scale);
  const bool lateral_on = fx.lateral_noise, flying_on = fx.flying_pixels;
  const bool dropout_on = fx.dropout, axial_on = fx.axial_noise;
  const bool noisy = lateral_on || flying_on || dropout_on || axial_on || burst;
  const float* Z = in.z;

  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      if (!noisy) {
        const float z = Z[i];
        if (z > 0 && z >= zmin && z <= zmax) out->setDepth(u, v, z + offset);
        continue;
      }
      const uint64_t bits = rng.next();
      size_t s = i;
      int su = u, sv = v;
      if (lateral_on) {
        const float g = std::sqrt(in.g2[i]);
        const float sigma_px = 0.8f + 0.035f * g;  // Fankhauser et al. 2015, lateral
        const int k = std::min(kLateralTables - 1, static_cast<int>((sigma_px - 0.8f) * 10.0f));
        su = std::clamp(u + lateral[k][bits & 0xFF], 0, W - 1);
        sv = std::clamp(v + lateral[k][(bits >> 8) & 0xFF], 0, H - 1);
        s = static_cast<size_t>(sv) * W + su;
      }
      float z = Z[s];
      if (!(z > 0)) continue;
      if (flying_on) {
        // Largest depth jump to a 4-neighbour of the source pixel.
        float znb = z, best = 0.0f;
        const int nu[4] = {su - 1, su + 1, su, su};
        const int nv[4] = {sv, sv, sv - 1, sv + 1};
        for (int q = 0; q < 4; ++q) {
          if (nu[q] < 0 || nu[q] >= W || nv[q] < 0 || nv[q] >= H) continue;
          const float zn = Z[static_cast<size_t>(nv[q]) * W + nu[q]];
          if (zn > 0 && std::abs(zn - z) > best) {
            best = std::abs(zn - z);
            znb = zn;
          }
        }
        if (best > jump && ((bits >> 16) & 0xFFFF) * (1.0f / 65536.0f) < flying_p) {
          const float w = ((bits >> 48) & 0xFFFF) * (1.0f / 65536.0f);
          z += w * (znb - z);
        }
      }
      if (z < zmin || z > zmax) continue;
      if (dropout_on) {
        const float a = in.reflectivity[s] * in.cos_incidence[s] / (z * z);
        const float p_drop = (a_hi - a) * inv_ramp;
        if (p_drop > 0 && ((bits >> 32) & 0xFFFF) * (1.0f / 65536.0f) < p_drop) continue;
      }
      if (axial_on) {
        const float sigma_mm = std::max(0.1f, kinect_v2::axialSigmaMm(z, in.g2[s]));
        const uint64_t nb = rng.next();
        z += axial_scale * sigma_mm * 1e-3f * normal[nb & 0xFFFF];
        if (burst && v >= band_v0 && v < band_v0 + band_h) {
          z += static_cast<float>(fx.interference_sigma) * normal[(nb >> 16) & 0xFFFF];
          if (((nb >> 32) & 0xFFFF) * (1.0f / 65536.0f) < fx.interference_dropout) continue;
        }
      } else if (burst && v >= band_v0 && v < band_v0 + band_h) {
        const uint64_t nb = rng.next();
        z += static_cast<float>(fx.interference_sigma) * normal[(nb >> 16) & 0xFFFF];
        if (((nb >> 32) & 0xFFFF) * (1.0f / 65536.0f) < fx.interference_dropout) continue;
      }
      z += offset;
      if (z > 0) out->setDepth(u, v, z);
    }
  }
}

}  // namespace drill_pipe_pose::sim
