#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "stages/track/stereo_matcher.h"
#include "stages/track/temporal_tracker.h"

namespace dg::stages {

// A fiducial seen in one rectified frame.
struct FiducialObservation {
  bool valid = false;
  cv::Point2f uv_left_R_px, uv_right_R_px;
  float quality = 0;  // the stereo match's NCC
};

// Follows a few known markers (registration's fiducials) in the rectified
// pair. Frame-to-frame tracking alone accumulates drift over a registration
// of several cardiac cycles, so each new position is then refined against the
// marker's appearance in the first frame (LK from the first image, started at
// the frame-to-frame estimate); the right position is a row search.
// Stateful: frames in order, one at a time.
class FiducialTracker {
 public:
  struct Options {
    TemporalTracker::Options temporal;
    StereoMatcher::Options stereo;
    std::string Validate() const;  // empty when valid
  };

  // uv_left_R_px: the fiducials in the first frame's rectified left image.
  // @throws dg::Error for invalid options or no fiducials.
  FiducialTracker(const Options& options, std::vector<cv::Point2f> uv_left_R_px);

  // The first call is the first frame. A fiducial once lost stays lost.
  // @pre CV_8UC1 rectified images of one size.
  std::vector<FiducialObservation> Process(const cv::Mat& left_R, const cv::Mat& right_R);

 private:
  Options options_;
  TemporalTracker temporal_;
  StereoMatcher stereo_;
  std::vector<cv::Point2f> first_uv_, uv_;
  std::vector<bool> alive_;
  // The first frame's pyramid, kept, and the last two frames', rebuilt in
  // place by turns, so that a frame allocates no pyramid.
  TemporalTracker::Pyramid first_;
  std::array<TemporalTracker::Pyramid, 2> recent_;
  long long frames_ = 0;  // processed so far
};

}  // namespace dg::stages
