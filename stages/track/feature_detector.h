#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "stages/track/feature.h"

namespace dg::stages {

// Finds trackable features in a rectified grey image: Shi-Tomasi corners and
// MSER region centroids, spread over the image by a grid of buckets so that
// the surface is sampled everywhere rather than only where texture is strongest.
// Stateless; Detect() is const and may run on several images at once; it
// uses TBB inside (the two kinds, and the tiles, at once).
class FeatureDetector {
 public:
  struct Options {
    bool corners = true;
    bool mser = true;
    int target_count = 500;      // features wanted over the whole image, existing ones included
    int grid_cols = 8, grid_rows = 6;
    int border_px = 12;          // no feature this close to the edge: the matchers need a window around it
    double min_distance_px = 7;  // between any two features, existing ones included
    double corner_quality = 0.02;  // Shi-Tomasi response relative to the image's strongest
    int corner_block_size = 5;
    int mser_delta = 5;
    int mser_min_area_px = 20, mser_max_area_px = 600;
    double mser_max_elongation = 4;  // major/minor axis: long thin regions localise poorly along their length
    std::string Validate() const;  // empty when valid
  };

  // @throws dg::Error naming the invalid option.
  explicit FeatureDetector(const Options& options);

  // Features of `image` (CV_8UC1) that keep min_distance_px from each other and
  // from `existing`, filling each bucket up to its share of target_count
  // (existing points count against their bucket), best response first; the
  // shares of buckets with too few candidates then go to the others. Only the
  // buckets short of their share are searched, so a frame that lost a few
  // tracks pays for a few tiles, not for the whole image.
  std::vector<Feature> Detect(const cv::Mat& image, const std::vector<cv::Point2f>& existing = {}) const;

  // The candidates of one kind before bucketing (for tests and tuning).
  std::vector<Feature> DetectCorners(const cv::Mat& image) const;
  std::vector<Feature> DetectMser(const cv::Mat& image) const;

  const Options& options() const { return options_; }

 private:
  // Corners at local maxima where `wanted` holds (sub-pixel refinement is the costly part).
  std::vector<Feature> DetectCorners(const cv::Mat& image,
                                     const std::function<bool(const cv::Point2f&)>& wanted) const;
  // MSER features centred in `bucket`, found in a tile around it.
  std::vector<Feature> DetectMserIn(const cv::Mat& image, const cv::Rect& bucket) const;

  Options options_;
};

}  // namespace dg::stages
