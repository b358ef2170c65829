#pragma once

#include <span>

namespace dg::sim {

// The q-quantile (0 <= q <= 1) of values by linear interpolation between
// order statistics (NumPy's default, Hyndman and Fan's definition 7): with
// x_0 <= ... <= x_{n-1} the sorted values and p = q (n - 1),
//   Q(q) = x_floor(p) + (p - floor(p)) (x_floor(p)+1 - x_floor(p)),
// so Q(0) is the smallest value, Q(1) the largest, and the median of an even
// count the mean of the two middle values. No values give 0, so that a
// summary of nothing reads as zeros; a q outside [0, 1] throws dg::Error.
// The values are copied, not reordered.
double Quantile(std::span<const double> values, double q);

// Quantile(values, 0.5).
double Median(std::span<const double> values);

}  // namespace dg::sim
