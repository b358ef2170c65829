#pragma once

#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

namespace dg::tools {

// One line of a plot: its name in the legend and its points, x ascending.
struct PlotSeries {
  std::string name;
  std::vector<cv::Point2d> points;
};

struct PlotOptions {
  std::string x_label, y_label;
  cv::Size size{1200, 600};
  // The y axis ends at this quantile of all values (times 1.1), so that one
  // outlier does not flatten every line; 1 shows everything. Points above the
  // axis are marked by a triangle on its top edge, in their series' colour,
  // and a note above the plot counts them and gives the largest.
  double y_quantile = 1.0;
  // Horizontal reference lines (e.g. the paper's figure), dashed, labelled.
  std::vector<std::pair<std::string, double>> references;
};

// What a plot could not show inside its axes.
struct PlotClipping {
  int points_above = 0;   // drawn as triangles on the top edge
  double y_axis_max = 0;  // where the y axis ends
  double largest_y = 0;   // the largest value of all
};

// A PNG for a person: the series as coloured lines (Tableau 10) over a grid,
// with axes, ticks, labels and a legend. y starts at 0.
// @throws dg::Error when the file cannot be written.
PlotClipping WriteLinePlot(const std::vector<PlotSeries>& series, const PlotOptions& options,
                           const std::string& png_path);

}  // namespace dg::tools
