#include "stages/track/marker_finder.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "stages/track/region_moments.h"

namespace dg::stages {
namespace {

// The interior level of a region: the upper quartile of its marker-ness, as
// interior pixels outnumber the anti-aliased rim of a disc of a few pixels' radius.
float InteriorLevel(std::vector<float> values) {
  const auto quartile = values.begin() + static_cast<std::ptrdiff_t>(values.size() * 3 / 4);
  std::nth_element(values.begin(), quartile, values.end());
  return *quartile;
}

}  // namespace

std::string MarkerFinder::Options::Validate() const {
  if (channel < 0 || channel > 2) return "channel must be 0 (blue), 1 (green) or 2 (red)";
  if (!(min_contrast > 0)) return "min_contrast must be positive";
  if (!(min_area_px > 0 && max_area_px > min_area_px)) return "need 0 < min_area_px < max_area_px";
  if (!(max_elongation >= 1)) return "max_elongation must be at least 1";
  return {};
}

MarkerFinder::MarkerFinder(const Options& options) : options_(options) {
  if (const std::string error = options.Validate(); !error.empty())
    throw Error("invalid marker finder options: " + error, "MarkerFinder::Options", "correct the option");
}

std::vector<Marker> MarkerFinder::Find(const cv::Mat& bgr) const {
  DG_CHECK(bgr.type() == CV_8UC3);
  cv::Mat channels[3];
  cv::split(bgr, channels);
  cv::Mat others, marker_ness;
  cv::max(channels[(options_.channel + 1) % 3], channels[(options_.channel + 2) % 3], others);
  cv::subtract(channels[options_.channel], others, marker_ness, cv::noArray(), CV_32F);
  const cv::Mat mask = marker_ness >= options_.min_contrast;
  cv::Mat labels;
  const int regions = cv::connectedComponents(mask, labels, 8, CV_32S);

  std::vector<std::vector<cv::Point>> pixels(regions);
  for (int r = 0; r < labels.rows; ++r) {
    const int* label = labels.ptr<int>(r);
    for (int c = 0; c < labels.cols; ++c)
      if (label[c] > 0) pixels[label[c]].emplace_back(c, r);
  }
  std::vector<Marker> markers;
  for (int region = 1; region < regions; ++region) {
    const std::vector<cv::Point>& points = pixels[region];
    std::vector<float> values;
    values.reserve(points.size());
    for (const cv::Point& p : points) values.push_back(marker_ness.at<float>(p));
    const float interior = InteriorLevel(values);
    RegionMoments moments;
    for (size_t i = 0; i < points.size(); ++i) moments.Add(points[i].x, points[i].y, std::min(1.0f, values[i] / interior));
    if (moments.weight() < options_.min_area_px || moments.weight() > options_.max_area_px ||
        !moments.Compact(options_.max_elongation)) {
      continue;
    }
    markers.push_back({moments.centroid(), static_cast<float>(moments.weight())});
  }
  std::sort(markers.begin(), markers.end(), [](const Marker& a, const Marker& b) { return a.area_px > b.area_px; });
  return markers;
}

}  // namespace dg::stages
