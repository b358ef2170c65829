#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace dg::stages {

// One stereo frame as it comes from the camera: BGR 8-bit images of one size.
// index counts from 0 and increases by one per frame; t_s is its time in the
// recording. Each eye has its own buffer (side-by-side input is split by copying).
struct StereoFrame {
  std::int64_t index = 0;
  double t_s = 0;
  cv::Mat left, right;
};

}  // namespace dg::stages
