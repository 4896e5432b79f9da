#pragma once
// Real roots of a x^2 + b x + c = 0, in the numerically stable form (no cancellation when
// b^2 >> 4ac): shared by the ray casts against surfaces of revolution (the estimator's model
// and the simulator's scene).
#include <cmath>

namespace drill_pipe_pose {

/// Writes the real roots (unordered) to roots[0..n) and returns n (0, 1 or 2). A (near-)zero `a`
/// makes it linear; a (near-)zero `a` and `b` has no root.
inline int solveQuadratic(double a, double b, double c, double roots[2]) {
  if (std::abs(a) < 1e-14) {
    if (std::abs(b) > 1e-15) {
      roots[0] = -c / b;
      return 1;
    }
    return 0;
  }
  const double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) return 0;
  const double sq = std::sqrt(disc);
  const double q = -0.5 * (b + (b >= 0.0 ? sq : -sq));
  int n = 0;
  roots[n++] = q / a;
  if (std::abs(q) > 1e-300) roots[n++] = c / q;
  return n;
}

}  // namespace drill_pipe_pose
