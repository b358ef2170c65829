#pragma once

// Table 1's figures of one run log, recomputed from its /errors datasets
// through the plain HDF5 C API, written out independently of tools/eval: the
// reference the evaluation tests hold the reports to. Header-only, for test
// files (Catch2's REQUIRE).
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "tests/support/h5_plain.h"

namespace dg::testing {

struct WindowErrors {
  double surface_avg = 0, surface_max = 0, surface_rms = 0;     // mm, pooled over the points seen
  double internal_avg = 0, internal_max = 0, internal_rms = 0;  // mm, over every internal point
  // The paper's typical feature: of the surface points seen in every frame of
  // the window, the one whose RMS error ranks size/2 (0-based) in ascending order.
  int typical_points = 0;
  double typical_avg = 0, typical_max = 0, typical_rms = 0;
};

// Over the log's first `window` simulated frames (rows of /errors).
inline WindowErrors ReadWindowErrors(hid_t file, int window) {
  using h5_plain::Doubles;
  const std::vector<double> n = Doubles(file, "/errors/surface_points");
  const std::vector<double> mean = Doubles(file, "/errors/surface_mean_mm");
  const std::vector<double> rms = Doubles(file, "/errors/surface_rms_mm");
  const std::vector<double> max = Doubles(file, "/errors/surface_max_mm");
  const std::vector<double> internal = Doubles(file, "/errors/internal_mm");
  REQUIRE(static_cast<int>(n.size()) >= window);
  const size_t points = internal.size() / n.size();
  WindowErrors errors;
  double total = 0, sum = 0, squares = 0, internal_sum = 0, internal_squares = 0;
  for (int k = 0; k < window; ++k) {
    total += n[k];
    sum += n[k] * mean[k];
    squares += n[k] * rms[k] * rms[k];
    errors.surface_max = std::max(errors.surface_max, max[k]);
    for (size_t p = 0; p < points; ++p) {
      const double e = internal[k * points + p];
      internal_sum += e;
      internal_squares += e * e;
      errors.internal_max = std::max(errors.internal_max, e);
    }
  }
  errors.surface_avg = sum / total;
  errors.surface_rms = std::sqrt(squares / total);
  errors.internal_avg = internal_sum / (window * points);
  errors.internal_rms = std::sqrt(internal_squares / (window * points));

  const std::vector<double> per_point = Doubles(file, "/errors/surface_mm");
  const size_t truth_points = per_point.size() / n.size();
  std::vector<std::pair<double, size_t>> ranked;  // (RMS, point) of the points seen throughout
  for (size_t p = 0; p < truth_points; ++p) {
    double squares = 0;
    int seen = 0;
    for (int k = 0; k < window; ++k) {
      const double e = per_point[k * truth_points + p];
      if (std::isnan(e)) break;
      squares += e * e;
      ++seen;
    }
    if (seen == window) ranked.emplace_back(std::sqrt(squares / window), p);
  }
  std::sort(ranked.begin(), ranked.end());
  errors.typical_points = static_cast<int>(ranked.size());
  REQUIRE(!ranked.empty());
  const size_t typical = ranked[ranked.size() / 2].second;
  double typical_squares = 0;
  for (int k = 0; k < window; ++k) {
    const double e = per_point[k * truth_points + typical];
    errors.typical_avg += e / window;
    errors.typical_max = std::max(errors.typical_max, e);
    typical_squares += e * e;
  }
  errors.typical_rms = std::sqrt(typical_squares / window);
  return errors;
}

}  // namespace dg::testing
