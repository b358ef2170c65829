#include "tools/report/line_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "sim/statistics.h"

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
cv::Scalar SeriesColour(size_t index) {
  static const cv::Scalar palette[] = {{180, 119, 31}, {14, 127, 255}, {44, 160, 44}, {40, 39, 214},
                                       {189, 103, 148}, {75, 86, 140}, {194, 119, 227}, {127, 127, 127},
                                       {34, 189, 188}, {207, 190, 23}};
  return palette[index % std::size(palette)];
}

}  // namespace

PlotClipping WriteLinePlot(const std::vector<PlotSeries>& series, const PlotOptions& options,
                           const std::string& png_path) {
  const cv::Size size = options.size;
  const int left = 80, right = 220, top = 40, bottom = 60;
  cv::Mat canvas(size, CV_8UC3, cv::Scalar(255, 255, 255));

  double first = INFINITY, last = -INFINITY;
  std::vector<double> all_y;
  for (const PlotSeries& line : series) {
    for (const cv::Point2d& p : line.points) {
      first = std::min(first, p.x);
      last = std::max(last, p.x);
      all_y.push_back(p.y);
    }
  }
  for (const auto& [name, y] : options.references) all_y.push_back(y);
  if (!(first < last)) {
    first = std::isfinite(first) ? first : 0;
    last = first + 1;
  }
  const double top_y = all_y.empty() ? 1.0 : sim::Quantile(all_y, options.y_quantile);
  const double y_max = top_y > 0 ? 1.1 * top_y : 1.0;
  PlotClipping clipping;
  clipping.y_axis_max = y_max;
  for (double y : all_y) clipping.largest_y = std::max(clipping.largest_y, y);
  const double plot_w = size.width - left - right, plot_h = size.height - top - bottom;
  auto at = [&](double x, double y) {
    return cv::Point(left + static_cast<int>((x - first) / (last - first) * plot_w),
                     top + static_cast<int>((1 - std::clamp(y, 0.0, y_max) / y_max) * plot_h));
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
  cv::putText(canvas, options.x_label, {left + static_cast<int>(plot_w / 2) - 20, size.height - 15},
              cv::FONT_HERSHEY_SIMPLEX, 0.55, ink, 1, cv::LINE_AA);
  cv::putText(canvas, options.y_label, {left - 60, top - 15}, cv::FONT_HERSHEY_SIMPLEX, 0.55, ink, 1, cv::LINE_AA);

  for (const auto& [name, y] : options.references) {
    for (double x = first; x < last; x += (last - first) / 60) {
      cv::line(canvas, at(x, y), at(std::min(last, x + (last - first) / 120), y), ink, 1, cv::LINE_AA);
    }
    cv::putText(canvas, name, at(last, y) + cv::Point(6, 5), cv::FONT_HERSHEY_SIMPLEX, 0.45, ink, 1, cv::LINE_AA);
  }
  int legend_row = 0;
  for (size_t k = 0; k < series.size(); ++k) {
    std::vector<cv::Point> polyline;
    for (const cv::Point2d& p : series[k].points) polyline.push_back(at(p.x, p.y));
    cv::polylines(canvas, polyline, false, SeriesColour(k), 1, cv::LINE_AA);
    for (const cv::Point2d& p : series[k].points) {
      if (p.y <= y_max) continue;
      const cv::Point apex = at(p.x, y_max);
      const std::vector<cv::Point> triangle = {apex, apex + cv::Point(-5, 9), apex + cv::Point(5, 9)};
      cv::fillConvexPoly(canvas, triangle, SeriesColour(k), cv::LINE_AA);
      ++clipping.points_above;
    }
    const cv::Point key(size.width - right + 20, top + 20 + 22 * legend_row++);
    cv::line(canvas, key, key + cv::Point(25, 0), SeriesColour(k), 3);
    cv::putText(canvas, series[k].name, key + cv::Point(32, 5), cv::FONT_HERSHEY_SIMPLEX, 0.5, ink, 1, cv::LINE_AA);
  }
  if (clipping.points_above > 0) {
    const std::string note = std::to_string(clipping.points_above) + " point" + (clipping.points_above > 1 ? "s" : "") +
                             " above the axis (triangles), largest " + Number(clipping.largest_y);
    cv::putText(canvas, note, {left + static_cast<int>(plot_w) - 9 * static_cast<int>(note.size()), top - 15},
                cv::FONT_HERSHEY_SIMPLEX, 0.5, ink, 1, cv::LINE_AA);
  }
  if (!cv::imwrite(png_path, canvas)) {
    throw Error("cannot write the plot", png_path, "check the directory exists and is writable");
  }
  return clipping;
}

}  // namespace dg::tools
