#pragma once

#include <opencv2/core.hpp>

namespace dg::stages {

// Where a feature came from: its detector decides how its position was found.
enum class FeatureKind { kCorner, kMser };

// A detected feature in the rectified left image R (pixels, (0,0) the centre
// of the top-left pixel). MSER features carry the region's moment ellipse
// (centre = uv_R_px); corners carry a zero-size one.
struct Feature {
  cv::Point2f uv_R_px;
  FeatureKind kind = FeatureKind::kCorner;
  cv::RotatedRect ellipse;
  float score = 0;  // detector response: larger is better, comparable within one kind only
};

}  // namespace dg::stages
