#include "tools/report/timing_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/error.h"

namespace dg::tools {
namespace {

// 1, 2 or 5 times a power of ten: about `ticks` steps over span.
double TickStep(double span, int ticks) {
  const double raw = span / ticks;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double factor : {1.0, 2.0, 5.0}) {
    if (factor * power >= raw) return factor * power;
  }
  return 10 * power;
}

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// Distinct colours (BGR) from the Tableau 10 palette.
cv::Scalar StageColour(size_t stage) {
  static const cv::Scalar palette[] = {{180, 119, 31}, {14, 127, 255}, {44, 160, 44}, {40, 39, 214},
                                       {189, 103, 148}, {75, 86, 140}, {194, 119, 227}, {127, 127, 127},
                                       {34, 189, 188}, {207, 190, 23}};
  return palette[stage % std::size(palette)];
}

}  // namespace

void WriteTimingPlot(const SavedRun& run, const std::string& png_path) {
  const cv::Size size(1200, 600);
  const int left = 80, right = 220, top = 40, bottom = 60;
  cv::Mat canvas(size, CV_8UC3, cv::Scalar(255, 255, 255));

  std::map<int, std::vector<cv::Point2d>> series;  // stage -> (frame, ms), frames ascending
  std::vector<double> all_ms;
  for (const pipeline::StageTiming& t : run.timings) {
    const double ms = (t.end_ns - t.start_ns) * 1e-6;
    series[t.stage].push_back({static_cast<double>(t.frame), ms});
    all_ms.push_back(ms);
  }
  double first = 0, last = 1;
  for (auto& [stage, points] : series) {
    std::sort(points.begin(), points.end(), [](auto& a, auto& b) { return a.x < b.x; });
    first = std::min(first, points.front().x);
    last = std::max(last, points.back().x);
  }
  // The scale follows the 99th percentile, so one slow outlier does not flatten every line.
  const double y_max = std::max(1.0, 1.1 * pipeline::Quantile(all_ms, 0.99));
  const double plot_w = size.width - left - right, plot_h = size.height - top - bottom;
  auto at = [&](double frame, double ms) {
    return cv::Point(left + static_cast<int>((frame - first) / (last - first) * plot_w),
                     top + static_cast<int>((1 - std::min(ms, y_max) / y_max) * plot_h));
  };

  const cv::Scalar ink(40, 40, 40), grid(225, 225, 225);
  const double y_step = TickStep(y_max, 6), x_step = TickStep(last - first, 8);
  for (double y = 0; y <= y_max; y += y_step) {
    cv::line(canvas, at(first, y), at(last, y), grid, 1);
    cv::putText(canvas, Number(y), at(first, y) + cv::Point(-45, 5), cv::FONT_HERSHEY_SIMPLEX, 0.45, ink, 1, cv::LINE_AA);
  }
  for (double x = std::ceil(first / x_step) * x_step; x <= last; x += x_step) {
    cv::line(canvas, at(x, 0), at(x, 0) + cv::Point(0, 5), ink, 1);
    cv::putText(canvas, Number(x), at(x, 0) + cv::Point(-10, 22), cv::FONT_HERSHEY_SIMPLEX, 0.45, ink, 1, cv::LINE_AA);
  }
  cv::rectangle(canvas, at(first, y_max), at(last, 0), ink, 1);
  cv::putText(canvas, "frame", {left + static_cast<int>(plot_w / 2) - 20, size.height - 15}, cv::FONT_HERSHEY_SIMPLEX,
              0.55, ink, 1, cv::LINE_AA);
  cv::putText(canvas, "ms per frame and stage", {left - 60, top - 15}, cv::FONT_HERSHEY_SIMPLEX, 0.55, ink, 1,
              cv::LINE_AA);

  int legend_row = 0;
  for (const auto& [stage, points] : series) {
    std::vector<cv::Point> polyline;
    for (const cv::Point2d& p : points) polyline.push_back(at(p.x, p.y));
    cv::polylines(canvas, polyline, false, StageColour(stage), 1, cv::LINE_AA);
    const cv::Point key(size.width - right + 20, top + 20 + 22 * legend_row++);
    cv::line(canvas, key, key + cv::Point(25, 0), StageColour(stage), 3);
    const std::string name = stage < static_cast<int>(run.stage_names.size()) ? run.stage_names[stage] : Number(stage);
    cv::putText(canvas, name, key + cv::Point(32, 5), cv::FONT_HERSHEY_SIMPLEX, 0.5, ink, 1, cv::LINE_AA);
  }
  if (!cv::imwrite(png_path, canvas)) {
    throw Error("cannot write the timing plot", png_path, "check the directory exists and is writable");
  }
}

}  // namespace dg::tools
