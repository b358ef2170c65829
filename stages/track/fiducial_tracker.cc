#include "stages/track/fiducial_tracker.h"

#include "sim/error.h"

namespace dg::stages {

std::string FiducialTracker::Options::Validate() const {
  if (std::string error = temporal.Validate(); !error.empty()) return error;
  return stereo.Validate();
}

FiducialTracker::FiducialTracker(const Options& options, std::vector<cv::Point2f> uv_left_R_px)
    : options_(options), temporal_(options.temporal), stereo_(options.stereo), first_uv_(std::move(uv_left_R_px)) {
  if (const std::string error = options.Validate(); !error.empty())
    throw Error("invalid fiducial tracker options: " + error, "FiducialTracker::Options", "correct the option");
  if (first_uv_.empty())
    throw Error("no fiducials to track", "FiducialTracker", "give the fiducials' first-frame positions");
  uv_ = first_uv_;
  alive_.assign(uv_.size(), true);
}

std::vector<FiducialObservation> FiducialTracker::Process(const cv::Mat& left_R, const cv::Mat& right_R) {
  if (frames_ == 0) {
    temporal_.BuildPyramid(left_R, &first_);
  } else {
    const TemporalTracker::Pyramid& previous = frames_ == 1 ? first_ : recent_[(frames_ - 1) % 2];
    TemporalTracker::Pyramid& pyramid = recent_[frames_ % 2];
    temporal_.BuildPyramid(left_R, &pyramid);
    std::vector<cv::Point2f> moved, anchored;
    std::vector<bool> tracked, refined;
    temporal_.Track(previous, pyramid, uv_, &moved, &tracked);
    temporal_.Track(first_, pyramid, first_uv_, &anchored, &refined, &moved);
    for (size_t i = 0; i < uv_.size(); ++i) {
      alive_[i] = alive_[i] && tracked[i];
      // The anchored position where the first frame's marker is still recognisable, else the frame-to-frame one.
      uv_[i] = refined[i] ? anchored[i] : moved[i];
    }
  }
  ++frames_;

  const std::vector<StereoMatch> matches = stereo_.Match(left_R, right_R, uv_);
  std::vector<FiducialObservation> observations(uv_.size());
  for (size_t i = 0; i < uv_.size(); ++i) {
    if (!alive_[i] || !matches[i].valid) continue;
    observations[i] = {true, uv_[i], uv_[i] - cv::Point2f(matches[i].disparity_px, 0), matches[i].score};
  }
  return observations;
}

}  // namespace dg::stages
