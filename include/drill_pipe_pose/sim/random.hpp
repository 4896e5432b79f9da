#pragma once
// Deterministic, fast random numbers for the simulator. Every stream is seeded from a hash of
// (scenario seed, stream id, camera index, frame index), so frames can be rendered in any order,
// on any machine, and come out bit-identical.

#include <cmath>
#include <cstdint>

namespace drill_pipe_pose::sim {

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): a good 64-bit mixing function.
inline uint64_t mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// Seed of one random stream from its coordinates.
inline uint64_t streamSeed(uint64_t seed, uint64_t stream, uint64_t a = 0, uint64_t b = 0) {
  return mix64(mix64(mix64(mix64(seed) ^ stream) ^ a) ^ b);
}

/// Named stream ids (keep stable: they define the simulator's output for a seed).
enum Stream : uint64_t {
  kStreamDepthNoise = 1,
  kStreamColorNoise = 2,
  kStreamDetector = 3,
  kStreamCameraSetup = 4,  ///< phases, depth offsets, calibration errors
  kStreamClockJitter = 5,
  kStreamWear = 6,
  kStreamInterference = 7,
  kStreamDepthScale = 8,
};

/// xoshiro256+ (Blackman, Vigna 2018), with uniform and normal helpers.
class Rng {
 public:
  explicit Rng(uint64_t seed) {
    for (auto& w : s_) {
      seed = mix64(seed);
      w = seed;
    }
  }
  /// 64 random bits.
  uint64_t next() {
    const uint64_t r = s_[0] + s_[3];
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = (s_[3] << 45) | (s_[3] >> 19);
    return r;
  }
  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  /// Uniform in [a, b).
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// Standard normal (Box-Muller, the second value is cached).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = uniform();
    if (u1 < 1e-300) u1 = 1e-300;
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double a = 2.0 * M_PI * u2;
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }
  /// Bernoulli trial with probability p.
  bool chance(double p) { return uniform() < p; }

 private:
  uint64_t s_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace drill_pipe_pose::sim
