#include "sim/statistics.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "sim/error.h"

namespace dg::sim {

double Quantile(std::span<const double> values, double q) {
  if (!(q >= 0 && q <= 1))
    throw Error("quantile " + std::to_string(q) + " is outside [0, 1]", "sim::Quantile",
                "pass q between 0 (the smallest value) and 1 (the largest)");
  if (values.empty()) return 0;
  std::vector<double> sorted(values.begin(), values.end());
  std::sort(sorted.begin(), sorted.end());
  const double position = q * static_cast<double>(sorted.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (position - static_cast<double>(below)) * (sorted[above] - sorted[below]);
}

double Median(std::span<const double> values) { return Quantile(values, 0.5); }

}  // namespace dg::sim
