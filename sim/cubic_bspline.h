#pragma once

namespace dg::sim {

// The uniform cubic B-spline on a knot interval, t in [0, 1) from its left
// knot: the weights of the four control points i-1 .. i+2 that the interval
// sees, and their derivatives with respect to t.
inline void CubicBSplineWeights(double t, double weights[4]) {
  const double s = 1 - t, t2 = t * t, t3 = t2 * t;
  weights[0] = s * s * s / 6;
  weights[1] = (3 * t3 - 6 * t2 + 4) / 6;
  weights[2] = (-3 * t3 + 3 * t2 + 3 * t + 1) / 6;
  weights[3] = t3 / 6;
}

inline void CubicBSplineDerivativeWeights(double t, double weights[4]) {
  const double s = 1 - t;
  weights[0] = -s * s / 2;
  weights[1] = (3 * t * t - 4 * t) / 2;
  weights[2] = (-3 * t * t + 2 * t + 1) / 2;
  weights[3] = t * t / 2;
}

}  // namespace dg::sim
