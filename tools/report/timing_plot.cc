// The plots of a run log over its frames: the stages' timings, the overlays' layer ages.
#include "tools/report/timing_plot.h"

#include <algorithm>
#include <map>

#include <fmt/format.h>

#include "sim/statistics.h"
#include "tools/report/line_plot.h"

namespace dg::tools {

PlotClipping WriteTimingPlot(const SavedRun& run, const std::string& png_path) {
  std::map<int, PlotSeries> series;  // by stage index: the legend in stage order
  for (const pipeline::StageTiming& t : run.timings) {
    PlotSeries& line = series[t.stage];
    if (line.name.empty()) {
      line.name = t.stage < static_cast<int>(run.stage_names.size()) ? run.stage_names[t.stage] : std::to_string(t.stage);
    }
    line.points.push_back({static_cast<double>(t.frame), (t.end_ns - t.start_ns) * 1e-6});
  }
  std::vector<PlotSeries> lines;
  for (auto& [stage, line] : series) {
    std::sort(line.points.begin(), line.points.end(), [](auto& a, auto& b) { return a.x < b.x; });
    lines.push_back(std::move(line));
  }
  PlotOptions options;
  options.x_label = "frame";
  options.y_label = "ms per frame and stage";
  options.y_quantile = 0.99;  // one slow outlier does not flatten every line
  return WriteLinePlot(lines, options, png_path);
}

PlotClipping WriteLayerAgePlot(const SavedRun& run, const std::string& png_path) {
  const size_t overlays = run.overlay_names.size();
  std::vector<PlotSeries> lines;
  for (size_t k = 0; k < overlays; ++k) {
    PlotSeries line{run.overlay_names[k], {}};
    // A frame composed without the layer has no age: no point (the axis starts at 0, which is a fresh layer).
    for (size_t row = 0; row < run.composite_frame.size(); ++row) {
      const std::int64_t age = run.layer_age_frames[row * overlays + k];
      if (age >= 0) line.points.push_back({static_cast<double>(run.composite_frame[row]), static_cast<double>(age)});
    }
    lines.push_back(std::move(line));
  }
  PlotOptions options;
  options.x_label = "frame";
  options.y_label = "layer age (frames since the state it was drawn from)";
  return WriteLinePlot(lines, options, png_path);
}

std::string LayerAgeSummary::Text() const {
  if (frames_with_layer == 0) return fmt::format("{}: no layer on any of {} composed frames", overlay, composed_frames);
  return fmt::format("{}: layer on {} of {} composed frames, age median {:g}, max {} frames", overlay,
                     frames_with_layer, composed_frames, median_age_frames, max_age_frames);
}

std::vector<LayerAgeSummary> SummarizeLayerAges(const SavedRun& run) {
  const size_t overlays = run.overlay_names.size();
  std::vector<LayerAgeSummary> summaries;
  for (size_t k = 0; k < overlays; ++k) {
    LayerAgeSummary summary;
    summary.overlay = run.overlay_names[k];
    summary.composed_frames = static_cast<std::int64_t>(run.composite_frame.size());
    std::vector<double> ages;
    for (size_t row = 0; row < run.composite_frame.size(); ++row) {
      const std::int64_t age = run.layer_age_frames[row * overlays + k];
      if (age < 0) continue;
      ages.push_back(static_cast<double>(age));
      summary.max_age_frames = std::max(summary.max_age_frames, age);
    }
    summary.frames_with_layer = static_cast<std::int64_t>(ages.size());
    if (!ages.empty()) summary.median_age_frames = sim::Median(ages);
    summaries.push_back(std::move(summary));
  }
  return summaries;
}

}  // namespace dg::tools
