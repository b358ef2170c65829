#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "io/calibration.h"
#include "stages/track/feature.h"
#include "stages/track/feature_detector.h"
#include "stages/track/stereo_matcher.h"
#include "stages/track/temporal_tracker.h"
#include "stages/track/triangulator.h"

namespace dg::stages {

// One surface point measured in one frame.
struct TrackedPoint {
  std::int64_t id = 0;  // persistent: the same material point keeps its id while it is tracked
  FeatureKind kind = FeatureKind::kCorner;
  Eigen::Vector2d uv_left_R_px, uv_right_R_px;  // rectified
  Eigen::Vector2d uv_left_px, uv_right_px;      // original, distorted
  Eigen::Vector3d xyz_C_m;                      // left camera frame
  double quality = 0;                           // the stereo match's NCC, in (min_score, 1]
  int age_frames = 0;                           // frames since detection
};

// Where Process() spent its time, for `dynaguide bench vision`: wall-clock
// milliseconds of each part of one call.
struct TrackTimings {
  double temporal_ms = 0;     // pyramid and Lucas-Kanade from the last frame
  double detect_ms = 0;       // zero in frames that need no new features
  double stereo_ms = 0;       // row search and sub-pixel refinement
  double triangulate_ms = 0;  // 3D points and distorted pixels of the matches
};

struct TrackFrame {
  std::vector<TrackedPoint> points;  // tracks with a stereo match in this frame
  int tracked = 0;                   // tracks alive after this frame, matched or not
  int detected = 0, lost = 0;        // tracks started and ended in this frame
};

// The tracking stage: features of the rectified left
// image followed from frame to frame, matched along the row into the right
// image and triangulated. Detection is the expensive part, so it runs only
// when the live count falls below a fraction of the target, and then only
// fills the buckets that lost tracks.
// Stateful: frames must come in order, one at a time (a serial node).
class FeatureTracker {
 public:
  struct Options {
    FeatureDetector::Options detector;
    // An 11 px window, not the temporal tracker's 15: on 3 levels it still
    // follows about 20 px per frame (the phantom's largest motion is 5 px),
    // costs half as much (Lucas-Kanade 4.6 -> 2.8 ms per frame on one core)
    // and drifts less on the phantom (median 0.20 px over 2 s, 0.23 with 15 px;
    // 3D error unchanged). Fiducials keep 15 px: their error grew with 11.
    TemporalTracker::Options temporal = [] {
      TemporalTracker::Options options;
      options.window_px = 11;
      return options;
    }();
    StereoMatcher::Options stereo;
    double redetect_fraction = 0.9;      // detect when fewer than this fraction of the target are alive
    double max_disparity_change_px = 3;  // between frames: a larger jump is a wrong stereo match
    int max_unmatched_frames = 3;        // a track without a stereo match for longer ends
    std::string Validate() const;        // empty when valid
  };

  // @throws dg::Error for invalid options or a calibration without rectification.
  FeatureTracker(const Options& options, const io::StereoCalibration& calibration);

  // @pre left_R and right_R are the rectified pair, CV_8UC1, of the same size as every earlier frame.
  // Into `frame`, reusing its storage; `timings` (optional) receives the time of each part.
  void Process(const cv::Mat& left_R, const cv::Mat& right_R, TrackFrame* frame, TrackTimings* timings = nullptr);
  TrackFrame Process(const cv::Mat& left_R, const cv::Mat& right_R, TrackTimings* timings = nullptr);

  const Triangulator& triangulator() const { return triangulator_; }

 private:
  struct Track {
    std::int64_t id;
    FeatureKind kind;
    cv::Point2f uv_R;
    float disparity = -1;  // the last matched disparity; negative before the first match
    int age = 0, unmatched = 0;
  };

  Options options_;
  FeatureDetector detector_;
  TemporalTracker temporal_;
  StereoMatcher stereo_;
  Triangulator triangulator_;
  // Two pyramids, swapped each frame: this frame's is built over the one
  // before the last, so once both have their sizes none is allocated.
  TemporalTracker::Pyramid previous_, current_;
  std::vector<Track> tracks_;
  // Per-frame working lists, kept for their capacity.
  std::vector<Track> kept_;
  std::vector<cv::Point2f> points_, moved_;
  std::vector<float> expected_;
  std::vector<bool> tracked_;
  std::int64_t next_id_ = 0;
};

// The tracker's default options with the stereo search limited to depths in
// [near_m, far_m] (far may be infinite), turned into a disparity range by the
// rectified calibration.
// @throws dg::Error naming --near/--far for an empty range, and --near for a
// near depth whose disparity is as wide as the image.
FeatureTracker::Options OptionsForDepthRange(const io::StereoCalibration& rectified, double near_m, double far_m);

}  // namespace dg::stages
