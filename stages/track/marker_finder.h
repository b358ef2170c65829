#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dg::stages {

// A coloured marker found in an image.
struct Marker {
  cv::Point2f uv_px;  // centroid, in the image's own pixels ((0,0) the centre of the top-left pixel)
  float area_px = 0;  // the marker's coverage summed over its pixels
};

// Finds the fiducials' coloured disc markers in a colour image (the first
// frame, before tracking starts), so a user need not click them. A pixel's
// marker-ness is how far its marker channel exceeds the larger of the other
// two (green markers on red tissue: G - max(B, R)), which the tissue's own
// colour and its shading leave near zero. Connected regions above a threshold
// of disc-like size and shape are markers; each centroid weighs a pixel by the
// fraction of it the marker covers (its marker-ness over the region's interior
// level, at most 1), so that anti-aliased edges count by their coverage and
// the shading across a marker does not pull the centroid to its lit side.
// Stateless.
class MarkerFinder {
 public:
  struct Options {
    int channel = 1;               // the marker's dominant channel in BGR order: 0 blue, 1 green, 2 red
    double min_contrast = 12;      // marker-ness (8-bit levels) of a marker pixel
    double min_area_px = 4, max_area_px = 5000;
    double max_elongation = 4;     // major/minor axis: a disc seen obliquely, not a vessel or a rim
    std::string Validate() const;  // empty when valid
  };

  // @throws dg::Error naming the invalid option.
  explicit MarkerFinder(const Options& options);

  // Markers of a CV_8UC3 (BGR) image, in order of decreasing area.
  std::vector<Marker> Find(const cv::Mat& bgr) const;

 private:
  Options options_;
};

}  // namespace dg::stages
