#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "tools/report/line_plot.h"
#include "tools/report/saved_run.h"

namespace dg::tools {

// A PNG for a person: each stage's time per frame (ms) against the frame
// number, one coloured line per stage, with axes, ticks and a legend. The
// y axis ends near the 99th percentile; frames above it are marked (PlotClipping).
// @throws dg::Error when the file cannot be written.
PlotClipping WriteTimingPlot(const SavedRun& run, const std::string& png_path);

// A PNG for a person: each overlay's layer age (frames since the state its
// layer was drawn from) against the frame number, one coloured line per
// overlay over the frames composed with its layer. A run without overlays
// (SavedRun::overlay_names empty) has an empty plot.
// @throws dg::Error when the file cannot be written.
PlotClipping WriteLayerAgePlot(const SavedRun& run, const std::string& png_path);

// One overlay's layer over a run: on how many composed frames it was laid, and how old it was there.
struct LayerAgeSummary {
  std::string overlay;
  std::int64_t composed_frames = 0;    // frames composed (with overlays or not)
  std::int64_t frames_with_layer = 0;  // of those, the frames with this overlay's layer
  double median_age_frames = std::numeric_limits<double>::quiet_NaN();  // over those frames; NaN when none
  std::int64_t max_age_frames = -1;    // likewise; -1 when none

  std::string Text() const;  // one line
};

// Per overlay in drawing order; none for a run without overlays.
std::vector<LayerAgeSummary> SummarizeLayerAges(const SavedRun& run);

}  // namespace dg::tools
