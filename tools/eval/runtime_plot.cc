#include "tools/eval/runtime_plot.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "tools/bench/bench_json.h"

namespace dg::tools {
namespace {

const cv::Scalar kInk(40, 40, 40), kGrid(225, 225, 225), kDominated(150, 150, 150), kFront(14, 127, 255),
    kRecommended(44, 160, 44);

void Text(cv::Mat& canvas, const std::string& text, cv::Point at, double scale, const cv::Scalar& colour) {
  cv::putText(canvas, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

}  // namespace

void WriteErrorRuntimePlot(const RuntimeResult& result, const std::string& png_path) {
  std::vector<const PointResult*> ran;
  for (const PointResult& p : result.points) {
    if (p.ran && p.simulating_realtime_factor > 0) ran.push_back(&p);
  }
  if (ran.empty()) throw Error("no point has run yet: nothing to plot", png_path, "run the sweep's points first");

  // x: log10 of the real-time factor, always showing 1.0x. y: the errors'
  // range with a margin (the configurations differ by tenths of their error:
  // from zero, the front would be a flat line); the axis says so.
  double x_lo = 1.0, x_hi = 1.0, y_lo = INFINITY, y_hi = 0;
  for (const PointResult* p : ran) {
    x_lo = std::min(x_lo, p->simulating_realtime_factor);
    x_hi = std::max(x_hi, p->simulating_realtime_factor);
    y_lo = std::min(y_lo, StudyInternalRmsMm(p->errors));
    y_hi = std::max(y_hi, StudyInternalRmsMm(p->errors));
  }
  const double log_lo = std::log10(x_lo) - 0.1, log_hi = std::log10(x_hi) + 0.15;
  const double margin = std::max(0.1 * (y_hi - y_lo), 0.05 * y_hi + 1e-3);
  y_lo = std::max(0.0, y_lo - margin);
  y_hi += margin;

  const cv::Size size(1200, 700);
  const int left = 90, right = 40, top = 90, bottom = 70;
  const double plot_w = size.width - left - right, plot_h = size.height - top - bottom;
  cv::Mat canvas(size, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto at = [&](double factor, double error_mm) {
    return cv::Point(left + static_cast<int>((std::log10(factor) - log_lo) / (log_hi - log_lo) * plot_w),
                     top + static_cast<int>((y_hi - error_mm) / (y_hi - y_lo) * plot_h));
  };
  const double x_min = std::pow(10.0, log_lo), x_max = std::pow(10.0, log_hi);

  // Ticks at 1, 2 and 5 per decade; y at 1, 2 or 5 times a power of ten, about six of them.
  for (int decade = static_cast<int>(std::floor(log_lo)); decade <= static_cast<int>(std::ceil(log_hi)); ++decade) {
    for (double mantissa : {1.0, 2.0, 5.0}) {
      const double x = mantissa * std::pow(10.0, decade);
      if (x < x_min || x > x_max) continue;
      cv::line(canvas, at(x, y_lo), at(x, y_hi), kGrid, 1);
      Text(canvas, Printed("%gx", x), at(x, y_lo) + cv::Point(-12, 22), 0.45, kInk);
    }
  }
  const double raw_step = (y_hi - y_lo) / 6, power = std::pow(10.0, std::floor(std::log10(raw_step)));
  const double y_step = raw_step <= power       ? power
                        : raw_step <= 2 * power ? 2 * power
                        : raw_step <= 5 * power ? 5 * power
                                                : 10 * power;
  for (double y = std::ceil(y_lo / y_step) * y_step; y <= y_hi; y += y_step) {
    cv::line(canvas, at(x_min, y), at(x_max, y), kGrid, 1);
    Text(canvas, Printed("%g", y), at(x_min, y) + cv::Point(-55, 5), 0.45, kInk);
  }
  cv::rectangle(canvas, at(x_min, y_hi), at(x_max, y_lo), kInk, 1);
  Text(canvas, "real-time factor while simulating (video s per wall s, log scale)",
       {left + static_cast<int>(plot_w / 2) - 250, size.height - 20}, 0.55, kInk);
  Text(canvas,
       "internal error of the overlay as shown, RMS (mm; the axis spans the points' range, not from 0): " +
           result.scene_name,
       {left - 70, 30}, 0.55, kInk);

  // Real time: a dashed vertical line, labelled on the side with room.
  for (double y = y_lo; y < y_hi; y += (y_hi - y_lo) / 40) {
    cv::line(canvas, at(1.0, y), at(1.0, std::min(y_hi, y + (y_hi - y_lo) / 80)), kInk, 2, cv::LINE_AA);
  }
  const bool label_left = at(1.0, y_lo).x + 160 > size.width - right;
  Text(canvas, "real time (1.0x)", at(1.0, y_lo) + cv::Point(label_left ? -150 : 8, -12), 0.5, kInk);

  // The Pareto front, joined from the slowest to the fastest.
  std::vector<const PointResult*> front;
  for (const PointResult* p : ran) {
    if (p->pareto) front.push_back(p);
  }
  std::sort(front.begin(), front.end(), [](const PointResult* a, const PointResult* b) {
    return a->simulating_realtime_factor < b->simulating_realtime_factor;
  });
  std::vector<cv::Point> line;
  for (const PointResult* p : front) line.push_back(at(p->simulating_realtime_factor, StudyInternalRmsMm(p->errors)));
  cv::polylines(canvas, line, false, kFront, 2, cv::LINE_AA);

  // Markers, then names: the front's first, each beside its marker where it
  // overlaps no name already drawn (the table names every point).
  std::stable_partition(ran.begin(), ran.end(), [](const PointResult* p) { return p->pareto; });
  std::vector<cv::Rect> taken;
  for (const PointResult* p : ran) {
    const cv::Point c = at(p->simulating_realtime_factor, StudyInternalRmsMm(p->errors));
    cv::circle(canvas, c, 6, p->pareto ? kFront : kDominated, cv::FILLED, cv::LINE_AA);
    if (result.recommended && &result.points[*result.recommended] == p) {
      cv::circle(canvas, c, 12, kRecommended, 2, cv::LINE_AA);
    }
    const std::string name = p->plan.point.Name();
    int baseline = 0;
    const cv::Size text = cv::getTextSize(name, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline);
    for (const cv::Point offset :
         {cv::Point(9, -7), cv::Point(9, 16), cv::Point(-9 - text.width, -7), cv::Point(-9 - text.width, 16)}) {
      const cv::Rect box(c + offset - cv::Point(0, text.height), cv::Size(text.width, text.height + baseline));
      const bool inside = box.x >= 0 && box.x + box.width < size.width;
      if (!inside || std::any_of(taken.begin(), taken.end(), [&](const cv::Rect& r) { return (r & box).area() > 0; })) {
        continue;
      }
      Text(canvas, name, c + offset, 0.4, p->pareto ? kInk : kDominated);
      taken.push_back(box);
      break;
    }
  }

  // The key, in one row above the plot.
  const cv::Point key(left + 10, top - 25);
  cv::circle(canvas, key, 6, kFront, cv::FILLED, cv::LINE_AA);
  Text(canvas, "Pareto front (non-dominated), joined", key + cv::Point(14, 5), 0.5, kInk);
  cv::circle(canvas, key + cv::Point(370, 0), 6, kDominated, cv::FILLED, cv::LINE_AA);
  Text(canvas, "dominated", key + cv::Point(384, 5), 0.5, kInk);
  cv::circle(canvas, key + cv::Point(510, 0), 12, kRecommended, 2, cv::LINE_AA);
  Text(canvas, "recommended for real time on 2 threads", key + cv::Point(530, 5), 0.5, kInk);

  if (!cv::imwrite(png_path, canvas)) {
    throw Error("cannot write the plot", png_path, "check the directory exists and is writable");
  }
}

}  // namespace dg::tools
