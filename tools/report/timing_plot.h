#pragma once

#include <string>

#include "tools/report/line_plot.h"
#include "tools/report/saved_run.h"

namespace dg::tools {

// A PNG for a person: each stage's time per frame (ms) against the frame
// number, one coloured line per stage, with axes, ticks and a legend. The
// y axis ends near the 99th percentile; frames above it are marked (PlotClipping).
// @throws dg::Error when the file cannot be written.
PlotClipping WriteTimingPlot(const SavedRun& run, const std::string& png_path);

}  // namespace dg::tools
