#pragma once
// The depth sensor effects as one per-pixel pass over what a ray caster found: the renderer
// (RigSimulator) and the board renderer (src/tools/render_board.cpp) share it, so that frames
// rendered for comparison with a real Kinect v2 go through exactly the simulator's model.

#include <cstdint>
#include <vector>

#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/sim/sensor_model.hpp"

namespace drill_pipe_pose::sim {

/// Per-pixel inputs of the depth sensor effects: what the ray caster found for each pixel of a
/// width x height depth image (row-major arrays of width * height values; z <= 0: no return).
/// The returned amplitude of a pixel is a = reflectivity cos_incidence / range^2 [1/m^2].
struct DepthSceneView {
  int width = 0, height = 0;             ///< [px]
  const float* z = nullptr;              ///< [m] along the optical axis
  const float* cos_incidence = nullptr;  ///< cos(angle between the ray and the surface normal)
  const float* reflectivity = nullptr;   ///< of the surface hit, for the dropout model
  const float* g2 = nullptr;             ///< incidence term of the noise model (incidenceTerm)
  /// z component of each pixel's unit ray: the returned amplitude falls with the range,
  /// depth / ray_z. nullptr: 1 (range = depth).
  const float* ray_z = nullptr;
};

/// Applies every enabled depth effect of `fx` (lateral noise at depth edges, flying pixels,
/// range limits, dropout and saturation by the returned amplitude, axial noise by range,
/// incidence and amplitude, optionally spatially correlated, interference bursts, the
/// brightness bias, the camera's depth scale and offset, quantisation) and writes the depth
/// image: 16UC1 millimetres with quantisation, else 32FC1 metres. A valid return z becomes
/// (z + noise + bias) * depth_scale + depth_offset [m]. noise_seed and interference_seed seed
/// the random streams (the renderer derives them from (seed, camera, frame): streamSeed with
/// kStreamDepthNoise and kStreamInterference). The random numbers are drawn in a fixed order: a
/// seed's frames never change.
/// With `amplitude`, also writes the IR amplitude image a driver publishes beside the depth
/// (kinect2_bridge's sd/image_ir_rect): each pixel with a return gets its amplitude a, of the
/// pixel its depth came from, in digital numbers (a x kinect_v2::kDnPerAmplitude, 16UC1); a
/// pixel whose depth was dropped keeps its amplitude, as a real IR image does. No random draw is
/// added: a seed's depth frames are the same with or without it.
void applyDepthEffects(const SensorEffects& fx, const DepthSceneView& in, double depth_offset,
                       double depth_scale, uint64_t noise_seed, uint64_t interference_seed,
                       DepthImage* out, AmplitudeImage* amplitude = nullptr);

/// Standard deviation [m] of the axial noise at depth z [m], incidence term g2 and returned
/// amplitude a = reflectivity cos(theta) / z^2 [1/m^2]: Fankhauser's sigma_z (times
/// axial_noise_scale), or with amplitude_noise the larger of it and sqrt(floor^2 + (C / a)^2).
float axialSigma(const SensorEffects& fx, float z, float g2, float amplitude);

/// Depth bias [m] (+ = farther) of a return of amplitude a [1/m^2] (0 when brightness_bias is
/// off): B (max(a, min_amplitude)^-p - reference^-p).
float brightnessBias(const SensorEffects& fx, float amplitude);

/// The incidence term g^2 = (theta / (pi/2 - theta))^2 of Fankhauser's model from cos(theta),
/// theta clamped to max_incidence_rad (kinect_v2::incidenceFactor, as a float).
float incidenceTerm(float cos_theta, double max_incidence_rad);

/// Standard normal by table lookup of 16 random bits: the inverse CDF at the 65536 bin centres
/// (exact mean 0, variance within 0.1 % of 1, tails to +-4.3 sigma). Fast enough to draw one
/// per pixel (depth and colour noise).
const std::vector<float>& normalTable();

}  // namespace drill_pipe_pose::sim
