#pragma once

#include <string>
#include <vector>

namespace dg::tools {

struct RegisterBenchOptions {
  std::vector<int> threads{1, 2};
  int repeats = 5;            // timed registrations per thread count; the median is reported
  int fiducials = 5;          // the paper's
  double cycles = 3;
  double sigma_px = 0.3;      // simulated tracking noise on the truth's pixels
};

// One line of the saved table. Times are of the whole registration (search,
// refinement, covariance, statistics), in milliseconds.
struct RegisterBenchRecord {
  int threads = 0;
  int fiducials = 0, frames = 0, observations = 0;
  double cycles = 0;
  double ms_median = 0, ms_max = 0;
  // Of the last repeat, against the phantom's truth.
  double rotation_error_deg = 0, translation_error_mm = 0, phase_shift_error_ms = 0;
  double residual_mm_left = 0, residual_mm_right = 0;
};

// Registration of a default-preset phantom (generated into a temporary folder
// and removed afterwards; 30 fps) from its truth's fiducial pixels with noise,
// per thread count.
std::vector<RegisterBenchRecord> RunRegisterBench(const RegisterBenchOptions& options, bool progress);

// Writes the records as a JSON list, each with the machine it ran on.
void WriteRegisterBenchJson(const std::string& path, const std::vector<RegisterBenchRecord>& records);

// A plain-text (Markdown) table of the records.
std::string RegisterBenchTable(const std::vector<RegisterBenchRecord>& records);

}  // namespace dg::tools
