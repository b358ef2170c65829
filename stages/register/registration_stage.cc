#include "stages/register/registration_stage.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "sim/error.h"

namespace dg::stages {

FiducialSighting SightingFromRectified(const FiducialObservation& observation, const Triangulator& geometry) {
  FiducialSighting sighting;
  if (!observation.valid) return sighting;
  sighting.in_left = sighting.in_right = true;
  sighting.uv_left_px = geometry.LeftToDistorted({observation.uv_left_R_px.x, observation.uv_left_R_px.y});
  sighting.uv_right_px = geometry.RightToDistorted({observation.uv_right_R_px.x, observation.uv_right_R_px.y});
  return sighting;
}

std::string RegistrationStage::Options::Validate() const {
  if (!(cycles >= 1)) return "cycles must be at least 1 (a whole cardiac cycle)";
  return solver.Validate();
}

RegistrationStage::RegistrationStage(const Options& options, FiducialMotion motion, io::StereoCalibration calibration,
                                     double period_s)
    : options_(options), motion_(std::move(motion)), calibration_(std::move(calibration)), period_s_(period_s) {
  if (const std::string wrong = options_.Validate(); !wrong.empty()) {
    throw Error("invalid registration stage options: " + wrong, "registration stage", "correct the option");
  }
  if (const std::string wrong = motion_.Validate(); !wrong.empty()) {
    throw Error("invalid fiducial motion: " + wrong, "registration stage", "check the scan's fiducial positions");
  }
  if (!(period_s_ > 0)) throw Error("the cardiac period must be positive", "registration stage", "give period_s");
}

bool RegistrationStage::Process(double t_s, std::vector<FiducialSighting> sightings) {
  if (complete_) return true;
  if (static_cast<int>(sightings.size()) != motion_.num_fiducials()) {
    throw Error("a frame with " + std::to_string(sightings.size()) + " fiducial sightings; the scan has " +
                    std::to_string(motion_.num_fiducials()),
                "registration stage at t = " + std::to_string(t_s) + " s",
                "track the scan's fiducials, in its order, in every frame");
  }
  window_.t_s.push_back(t_s);
  window_.frames.push_back(std::move(sightings));
  // The frame just added covers [t_s, t_s + one frame interval).
  const size_t n = window_.t_s.size();
  if (n >= 2) {
    const double frame_s = (window_.t_s.back() - window_.t_s.front()) / double(n - 1);
    complete_ = window_.t_s.back() - window_.t_s.front() + frame_s >= options_.cycles * period_s_ * (1 - 1e-9);
  }
  return complete_;
}

const RegistrationResult& RegistrationStage::Solve() {
  if (!result_) result_ = RegisterScanToVideo(motion_, calibration_, period_s_, window_, options_.solver);
  return *result_;
}

FiducialTracker StartFiducialTracker(const Triangulator& geometry, const std::vector<Eigen::Vector2d>& first_uv_left_px,
                                     double near_m, double far_m) {
  std::vector<cv::Point2f> start;
  for (size_t i = 0; i < first_uv_left_px.size(); ++i) {
    Eigen::Vector2d uv_R;
    if (!geometry.LeftToRectified(first_uv_left_px[i], &uv_R)) {
      throw Error("fiducial " + std::to_string(i) + "'s first-frame pixel is outside the calibrated field",
                  "registration", "give the fiducial's pixel in the first left frame (registration.fiducials_uv)");
    }
    start.emplace_back(static_cast<float>(uv_R.x()), static_cast<float>(uv_R.y()));
  }
  FiducialTracker::Options options;
  std::tie(options.stereo.min_disparity_px, options.stereo.max_disparity_px) = geometry.DisparityRange(near_m, far_m);
  return FiducialTracker(options, start);
}

}  // namespace dg::stages
