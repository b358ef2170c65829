#pragma once

#include <string>

#include "tools/eval/stability_study.h"

namespace dg::tools {

// The study's outputs, from its results (as read back from the logs):
// stability.md (outcome counts, each material's limits, the bisections, and
// per motion and guard a table of E x nu against dt), stability.csv (one row
// per cell), bisection.csv, and stability_heatmap.png (per motion and guard a
// row of E x nu panels, one per dt, one colour per outcome).
// @returns the markdown. @throws dg::Error when a file cannot be written.
std::string WriteStabilityReport(const StabilityResult& result, const std::string& out_dir);

// The JSON users script against: per cell its name, axes, outcome, limits,
// substeps, internal steps and wall time; per bisection the limits and ratios.
// @throws dg::Error when the file cannot be written.
void WriteStabilityJson(const StabilityResult& result, const std::string& path);

}  // namespace dg::tools
