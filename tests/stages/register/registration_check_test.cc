// The registration checks itself: tracks in another order than the scan's
// fiducials are reassigned, tracks beside their markers, a symmetric layout,
// noisy tracks and a shift the tracks cannot pin down are refused, and the
// reported uncertainty covers the error of an irregular beat, over seeds.
#include <cmath>
#include <random>
#include <utility>

#include <Eigen/Geometry>

#include "sim/error.h"
#include "stages/register/fiducial_assignment.h"
#include "stages/register/registration.h"
#include "tests/stages/register/synthetic_registration.h"

// Ceres brings glog, whose CHECK would abort where Catch's reports: Catch's wins.
#undef CHECK
#include <catch2/catch.hpp>

namespace dg::stages {
namespace {

using Catch::Matchers::Contains;

constexpr double kShift_s = 0.2345;

FiducialTracks Swapped(FiducialTracks tracks, int a, int b) {
  for (auto& frame : tracks.frames) std::swap(frame[a], frame[b]);
  return tracks;
}

void AddNoise(FiducialTracks* tracks, double sd_px, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sd_px);
  for (auto& frame : tracks->frames) {
    for (FiducialSighting& s : frame) {
      s.uv_left_px += Eigen::Vector2d(noise(rng), noise(rng));
      s.uv_right_px += Eigen::Vector2d(noise(rng), noise(rng));
    }
  }
}

double TranslationError_m(const io::Registration& r) {
  return (r.T_C_S.topRightCorner<3, 1>() - TruePose().translation()).norm();
}

TEST_CASE("register check: tracks given in another order are reassigned and register exactly", "[register][unit]") {
  const FiducialMotion motion = SyntheticMotion(5, 20);
  const io::StereoCalibration calibration = SyntheticCalibration();
  const FiducialTracks tracks = Swapped(Swapped(SyntheticTracks(motion, calibration, TruePose(), kShift_s, 3), 0, 1), 2, 4);
  const RegistrationResult result = RegisterScanToVideo(motion, calibration, kPeriod_s, tracks, {});
  REQUIRE(result.assignment.verdict == FiducialAssignment::Verdict::kReassigned);
  REQUIRE(result.assignment.scan_of_track == std::vector<int>{1, 0, 4, 3, 2});
  // Exact sightings: the mean positions fit to 0.028 px (the mean of a
  // projection against the projection of the mean), the order given by tens
  // of pixels.
  REQUIRE(result.assignment.rms_px < 0.06);
  REQUIRE(result.assignment.given_rms_px > 20);
  REQUIRE(TranslationError_m(result.registration) < 1e-7);
  REQUIRE(std::abs(PhaseError_s(result.registration.phase_shift_s, kShift_s)) < 1e-6);
}

// Each track a few millimetres beside its marker, in its own direction, as
// when a first-frame pixel lands on the tissue next to the bead.
TEST_CASE("register check: tracks beside their markers are refused, naming the one farthest from the others",
          "[register][unit]") {
  const FiducialMotion motion = SyntheticMotion(5, 20);
  const io::StereoCalibration calibration = SyntheticCalibration();
  FiducialMotion beside = motion;
  for (Eigen::Matrix3Xd& x : beside.positions_S_m) {
    for (int i = 0; i < x.cols(); ++i) x.col(i) += 2e-3 * Eigen::Vector3d(std::cos(2.0 * i), std::sin(2.0 * i), 0.3 * i - 0.6);
  }
  const FiducialTracks tracks = SyntheticTracks(beside, calibration, TruePose(), kShift_s, 3);
  REQUIRE_THROWS_WITH(RegisterScanToVideo(motion, calibration, kPeriod_s, tracks, {}),
                      Contains("fit the scan's fiducials in no order") &&
                          Contains("departs") && Contains("from the pose the others fit") &&
                          Contains("registration.fiducials_uv"));
}

// Four markers on an ellipse at right angles: the layout is the same turned
// half a turn, so an order that is not given cannot be told from its image.
TEST_CASE("register check: a wrong order on a symmetric layout is refused as ambiguous", "[register][unit]") {
  const FiducialMotion motion = SyntheticMotion(4, 20);
  const io::StereoCalibration calibration = SyntheticCalibration();
  const FiducialTracks tracks = Swapped(SyntheticTracks(motion, calibration, TruePose(), kShift_s, 3), 0, 1);
  REQUIRE_THROWS_WITH(RegisterScanToVideo(motion, calibration, kPeriod_s, tracks, {}),
                      Contains("more than one other order fits") && Contains("symmetrically"));
  const FiducialAssignment assignment = AssignFiducials(motion, calibration, tracks, 1.5);
  REQUIRE(assignment.verdict == FiducialAssignment::Verdict::kAmbiguous);
}

TEST_CASE("register check: residuals far above tracking noise are refused", "[register][unit]") {
  const FiducialMotion motion = SyntheticMotion(5, 20);
  const io::StereoCalibration calibration = SyntheticCalibration();
  FiducialTracks tracks = SyntheticTracks(motion, calibration, TruePose(), kShift_s, 3);
  AddNoise(&tracks, 0.5, 7);  // tracking noise: registers
  REQUIRE_NOTHROW(RegisterScanToVideo(motion, calibration, kPeriod_s, tracks, {}));
  AddNoise(&tracks, 5.0, 8);  // 5 px per axis more, 6 px rms: the motion no longer explains the tracks
  RegistrationOptions options;
  options.assignment_tolerance_px = 100;  // leave the verdict to the residuals
  REQUIRE_THROWS_WITH(RegisterScanToVideo(motion, calibration, kPeriod_s, tracks, options),
                      Contains("px rms (at most 5.00 px") && Contains("does not explain the tracks"));
}

// A beat that repeats twice per scan cycle: shifts half a period apart explain
// the tracks equally, so the shift is not determined.
TEST_CASE("register check: a shift the tracks cannot pin down is refused as not unique", "[register][unit]") {
  FiducialMotion motion = SyntheticMotion(5, 20);
  const FiducialMotion twice = SyntheticMotion(5, 10);
  for (int k = 0; k < 20; ++k) motion.positions_S_m[k] = twice.positions_S_m[k % 10];
  const io::StereoCalibration calibration = SyntheticCalibration();
  FiducialTracks tracks = SyntheticTracks(motion, calibration, TruePose(), kShift_s, 3);
  AddNoise(&tracks, 0.3, 3);
  REQUIRE_THROWS_WITH(RegisterScanToVideo(motion, calibration, kPeriod_s, tracks, {}),
                      Contains("not unique") && Contains("registration.cycles"));
}

// Sightings of a beat whose every cycle lasts the nominal period times
// (1 + d), d drawn with the given standard deviation, plus tracking noise:
// the scan's motion (one period) explains them only approximately, and the
// errors of the window's frames are correlated over whole cycles.
FiducialTracks IrregularTracks(const FiducialMotion& motion, const io::StereoCalibration& calibration, double period_sd,
                               double noise_px, unsigned seed, std::vector<double>* true_phase) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> variation(0.0, period_sd);
  std::vector<double> cycle_start = {0};
  while (cycle_start.back() < 4 * kPeriod_s) cycle_start.push_back(cycle_start.back() + kPeriod_s * (1 + variation(rng)));
  FiducialTracks tracks;
  const int frames = static_cast<int>(std::ceil(3 * kPeriod_s * kFps - 1e-9));
  for (int j = 0; j < frames; ++j) {
    const double t = j / kFps, beat_s = t + kShift_s;
    size_t c = 0;
    while (cycle_start[c + 1] <= beat_s) ++c;
    const double phase = c + (beat_s - cycle_start[c]) / (cycle_start[c + 1] - cycle_start[c]);
    true_phase->push_back(phase);
    std::vector<FiducialSighting> frame;
    for (int i = 0; i < motion.num_fiducials(); ++i) {
      Eigen::Vector3d x_S;
      FiducialAtPhase(motion, i, phase, x_S.data());
      const Eigen::Vector3d x_C = TruePose() * x_S;
      frame.push_back({true, true, Project(calibration.left, x_C), Project(calibration.right, calibration.R * x_C + calibration.T_m)});
    }
    tracks.t_s.push_back(t);
    tracks.frames.push_back(frame);
  }
  AddNoise(&tracks, noise_px, seed + 1000);
  return tracks;
}

// Over 24 beats with 4% cycle-to-cycle variation (the phantom's default),
// the error in units of the reported sigma: the shift's error is the window's
// mean phase error (what a constant shift can get right), the translation's
// the distance to the true pose. Ceres' covariance alone, which takes the
// residuals as independent, is over-confident here: an rms of 3.6 for the
// shift and 1.7 for the translation. With the jackknife it is 0.22 and 0.46:
// never over-confident, and cautious by 2 to 4 (the window's own mean phase
// is what the shift estimates; the blocks' solutions spread wider).
TEST_CASE("register check: the reported uncertainty covers an irregular beat's error over seeds", "[register][unit]") {
  // The synthetic markers sweep tens of pixels a cycle; at a third of that
  // beat (as the phantom's markers at their distance), 4% off leaves residuals
  // of a few pixels, as on the phantom.
  FiducialMotion motion = SyntheticMotion(5, 20);
  Eigen::Matrix3Xd mean = Eigen::Matrix3Xd::Zero(3, 5);
  for (const Eigen::Matrix3Xd& x : motion.positions_S_m) mean += x / 20;
  for (Eigen::Matrix3Xd& x : motion.positions_S_m) x = mean + (x - mean) / 3;
  const io::StereoCalibration calibration = SyntheticCalibration();
  double shift_z2 = 0, translation_z2 = 0;
  const int seeds = 24;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::vector<double> true_phase;
    const FiducialTracks tracks = IrregularTracks(motion, calibration, 0.04, 0.3, seed, &true_phase);
    const io::Registration r = RegisterScanToVideo(motion, calibration, kPeriod_s, tracks, {}).registration;
    double mean_error_s = 0;
    for (size_t j = 0; j < true_phase.size(); ++j) {
      mean_error_s += PhaseError_s((tracks.t_s[j] + r.phase_shift_s), true_phase[j] * kPeriod_s) / true_phase.size();
    }
    shift_z2 += std::pow(mean_error_s / std::sqrt(r.covariance(6, 6)), 2) / seeds;
    translation_z2 += std::pow(TranslationError_m(r) / std::sqrt(r.covariance.block<3, 3>(3, 3).trace()), 2) / seeds;
  }
  CAPTURE(std::sqrt(shift_z2), std::sqrt(translation_z2));
  CHECK(std::sqrt(shift_z2) < 1.5);
  CHECK(std::sqrt(translation_z2) < 1.5);
  CHECK(std::sqrt(shift_z2) > 0.1);  // cautious, not meaningless
  CHECK(std::sqrt(translation_z2) > 0.2);
}

}  // namespace
}  // namespace dg::stages
