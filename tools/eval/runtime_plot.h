#pragma once

#include <string>

#include "tools/eval/runtime_sweep.h"

namespace dg::tools {

// error_vs_runtime.png: one marker per point that ran, internal RMS error (mm,
// over the points' range) against the simulating real-time factor on a
// logarithmic axis (the points span hundredths to several times real time),
// named where the names do not overlap; the Pareto front joined in order of
// speed, the recommended point ringed, and a dashed vertical line at real time (1.0x).
// @throws dg::Error when no point ran, or the file cannot be written.
void WriteErrorRuntimePlot(const RuntimeResult& result, const std::string& png_path);

}  // namespace dg::tools
