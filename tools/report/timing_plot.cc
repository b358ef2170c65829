#include "tools/report/timing_plot.h"

#include <algorithm>
#include <map>

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

}  // namespace dg::tools
