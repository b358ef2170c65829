// The plots a person reads: what the y axis cannot show is marked and counted.
#include "tools/report/line_plot.h"

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/support/temporary_folder.h"

namespace dg::tools {
namespace {

// 100 frames at 1 ms and one at 50 ms: the axis ends at 1.1 x the 99th
// percentile, so the outlier is above it and marked by a triangle hanging
// from the top edge at its frame, in its series' colour (Tableau 10's first).
TEST_CASE("line plot: a point above the axis is marked at its x and counted", "[tools][unit]") {
  PlotSeries line{"track", {}};
  for (int x = 0; x <= 100; ++x) line.points.push_back({double(x), x == 50 ? 50.0 : 1.0});
  PlotOptions options;
  options.y_quantile = 0.99;
  const testing::TemporaryFolder folder("dg_line_plot");
  const std::string path = folder.File("clipped.png");
  const PlotClipping clipping = WriteLinePlot({line}, options, path);
  CHECK(clipping.points_above == 1);
  CHECK(clipping.y_axis_max == Approx(1.1));
  CHECK(clipping.largest_y == 50.0);
  // The plot area is x 80..980 for frames 0..100 and starts at y 40.
  const cv::Mat image = cv::imread(path);
  const cv::Vec3b first_colour(180, 119, 31);  // BGR
  CHECK(image.at<cv::Vec3b>(46, 80 + 450) == first_colour);  // inside the triangle under the edge
  CHECK(image.at<cv::Vec3b>(46, 80 + 250) == cv::Vec3b(255, 255, 255));  // no mark where nothing was clipped

  options.y_quantile = 1.0;  // the axis holds everything: nothing marked
  CHECK(WriteLinePlot({line}, options, path).points_above == 0);
}

}  // namespace
}  // namespace dg::tools
