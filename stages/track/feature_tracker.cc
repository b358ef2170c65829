#include "stages/track/feature_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <tuple>

#include "sim/error.h"
#include "stages/track/stereo_pair_check.h"

namespace dg::stages {
namespace {

// Milliseconds since `*start`, which moves on to now: consecutive calls time consecutive parts.
double Lap(std::chrono::steady_clock::time_point* start) {
  const auto now = std::chrono::steady_clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - *start).count();
  *start = now;
  return ms;
}

}  // namespace

std::string FeatureTracker::Options::Validate() const {
  for (const std::string& error : {detector.Validate(), temporal.Validate(), stereo.Validate()})
    if (!error.empty()) return error;
  if (redetect_fraction <= 0 || redetect_fraction > 1) return "redetect_fraction must be in (0, 1]";
  if (max_disparity_change_px <= 0) return "max_disparity_change_px must be positive";
  if (max_unmatched_frames < 0) return "max_unmatched_frames must not be negative";
  return {};
}

FeatureTracker::FeatureTracker(const Options& options, const io::StereoCalibration& calibration)
    : options_(options),
      detector_(options.detector),
      temporal_(options.temporal),
      stereo_(options.stereo),
      triangulator_(calibration) {
  if (const std::string error = options.Validate(); !error.empty())
    throw Error("invalid feature tracker options: " + error, "FeatureTracker::Options", "correct the option");
}

TrackFrame FeatureTracker::Process(const cv::Mat& left_R, const cv::Mat& right_R, TrackTimings* timings) {
  TrackFrame frame;
  Process(left_R, right_R, &frame, timings);
  return frame;
}

void FeatureTracker::Process(const cv::Mat& left_R, const cv::Mat& right_R, TrackFrame* frame, TrackTimings* timings) {
  TrackTimings spent;
  auto start = std::chrono::steady_clock::now();
  const bool first_pair = previous_.empty();
  frame->points.clear();
  frame->detected = frame->lost = 0;
  temporal_.BuildPyramid(left_R, &current_);
  if (!previous_.empty() && !tracks_.empty()) {
    points_.clear();
    for (const Track& t : tracks_) points_.push_back(t.uv_R);
    temporal_.Track(previous_, current_, points_, &moved_, &tracked_);
    kept_.clear();
    for (size_t i = 0; i < tracks_.size(); ++i) {
      if (!tracked_[i]) continue;
      kept_.push_back(tracks_[i]);
      kept_.back().uv_R = moved_[i];
      ++kept_.back().age;
    }
    frame->lost = static_cast<int>(tracks_.size() - kept_.size());
    std::swap(tracks_, kept_);
  }
  std::swap(previous_, current_);
  spent.temporal_ms = Lap(&start);

  if (tracks_.size() < options_.redetect_fraction * options_.detector.target_count) {
    std::vector<cv::Point2f> existing;
    for (const Track& t : tracks_) existing.push_back(t.uv_R);
    for (const Feature& f : detector_.Detect(left_R, existing)) tracks_.push_back({next_id_++, f.kind, f.uv_R_px});
    frame->detected = static_cast<int>(tracks_.size() - existing.size());
  }
  spent.detect_ms = Lap(&start);

  points_.clear();
  expected_.clear();
  for (const Track& t : tracks_) {
    points_.push_back(t.uv_R);
    expected_.push_back(t.disparity);
  }
  const std::vector<StereoMatch> matches = stereo_.Match(left_R, right_R, points_, &expected_);
  if (first_pair) CheckFirstStereoPair(left_R, right_R, points_, matches);
  spent.stereo_ms = Lap(&start);
  kept_.clear();
  for (size_t i = 0; i < tracks_.size(); ++i) {
    Track& t = tracks_[i];
    const StereoMatch& m = matches[i];
    const bool consistent =
        m.valid && (t.disparity < 0 || std::abs(m.disparity_px - t.disparity) <= options_.max_disparity_change_px);
    if (!consistent) {
      if (++t.unmatched <= options_.max_unmatched_frames) kept_.push_back(t);
      else ++frame->lost;
      continue;
    }
    t.unmatched = 0;
    t.disparity = m.disparity_px;
    kept_.push_back(t);
    TrackedPoint& p = frame->points.emplace_back();
    p.id = t.id;
    p.kind = t.kind;
    p.uv_left_R_px = Eigen::Vector2d(t.uv_R.x, t.uv_R.y);
    p.uv_right_R_px = p.uv_left_R_px - Eigen::Vector2d(m.disparity_px, 0);
    p.uv_left_px = triangulator_.LeftToDistorted(p.uv_left_R_px);
    p.uv_right_px = triangulator_.RightToDistorted(p.uv_right_R_px);
    p.xyz_C_m = triangulator_.Triangulate(p.uv_left_R_px, m.disparity_px);
    p.quality = m.score;
    p.age_frames = t.age;
  }
  std::swap(tracks_, kept_);
  frame->tracked = static_cast<int>(tracks_.size());
  spent.triangulate_ms = Lap(&start);
  if (timings) *timings = spent;
}

FeatureTracker::Options OptionsForDepthRange(const io::StereoCalibration& rectified, double near_m, double far_m) {
  FeatureTracker::Options options;
  std::tie(options.stereo.min_disparity_px, options.stereo.max_disparity_px) =
      Triangulator(rectified).DisparityRange(near_m, far_m);
  if (options.stereo.max_disparity_px >= rectified.left.width) {
    throw Error("the near depth " + std::to_string(near_m) + " m is a disparity of " +
                    std::to_string(options.stereo.max_disparity_px) + " px, wider than the image",
                "--near", "give a larger near depth");
  }
  return options;
}

}  // namespace dg::stages
