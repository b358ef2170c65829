#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "stages/track/stereo_matcher.h"

namespace dg::stages {

// The first rectified stereo pair's sanity, checked once when tracking
// starts: a recording whose eyes are swapped otherwise tracks a handful of
// points, and the run blames what comes after (fiducials, registration).
// In a rectified pair the scene appears in the right eye shifted left (by
// its disparity), so the pair's dominant translation (phase correlation) is
// negative along the rows. When fewer than half the points match along
// their rows and the translation is positive, the eyes are swapped.
// `matches` are the matcher's for `points` in the pair as given.
// @throws dg::Error naming the cause and the fix.
void CheckFirstStereoPair(const cv::Mat& left_R, const cv::Mat& right_R, const std::vector<cv::Point2f>& points,
                          const std::vector<StereoMatch>& matches);

}  // namespace dg::stages
