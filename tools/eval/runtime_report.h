#pragma once

#include <string>

#include "tools/eval/runtime_sweep.h"

namespace dg::tools {

// Writes the sweep's report into out_dir: report.md (the design, the table
// with the Pareto front marked, the recommendation), runtime.csv (one row per
// point, every figure; refused and failed points with their reason) and
// error_vs_runtime.png (internal RMS error against the simulating real-time
// factor, the front joined, real time marked).
// @returns the report's text. @throws dg::Error when a file cannot be written.
std::string WriteRuntimeReport(const RuntimeResult& result, const std::string& out_dir);

// The recommendation sentence of the report (RecommendForRealTime on 2 threads).
std::string RecommendationText(const RuntimeResult& result);

// Per point: name, tets, dt_ms, threads, precision, target_features, status,
// surface_avg_mm, surface_max_mm, surface_rms_mm, internal_avg_mm,
// internal_max_mm, internal_rms_mm, realtime_factor,
// simulating_realtime_factor, pareto, recommended.
// @throws dg::Error when the file cannot be written.
void WriteRuntimeJson(const RuntimeResult& result, const std::string& path);

}  // namespace dg::tools
