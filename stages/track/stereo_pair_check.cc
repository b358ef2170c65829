#include "stages/track/stereo_pair_check.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

#include "sim/error.h"

namespace dg::stages {
namespace {

// Too few points say nothing about the pair (a dark or featureless frame).
constexpr std::size_t kMinPoints = 20;
// A translation this small is no evidence either way (a scene far away).
constexpr double kMinShiftPx = 1.0;

}  // namespace

void CheckFirstStereoPair(const cv::Mat& left_R, const cv::Mat& right_R, const std::vector<cv::Point2f>& points,
                          const std::vector<StereoMatch>& matches) {
  const auto valid = static_cast<std::size_t>(
      std::count_if(matches.begin(), matches.end(), [](const StereoMatch& m) { return m.valid; }));
  if (points.size() < kMinPoints || 2 * valid >= points.size()) return;
  cv::Mat left, right;
  left_R.convertTo(left, CV_32F);
  right_R.convertTo(right, CV_32F);
  const cv::Point2d shift = cv::phaseCorrelate(left, right);
  if (shift.x <= kMinShiftPx) return;
  char found[160];
  std::snprintf(found, sizeof found,
                "%zu of %zu points match along their rows, and the right image is shifted %.1f px to the right of "
                "the left (a correct pair shifts it left)",
                valid, points.size(), shift.x);
  throw Error(std::string("the left and right eyes look swapped: ") + found, "the first stereo pair",
              "exchange the scene's video.left and video.right (or --left and --right), or check that the "
              "calibration's first camera is the left eye");
}

}  // namespace dg::stages
