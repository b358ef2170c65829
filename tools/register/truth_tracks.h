#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "stages/register/registration.h"

namespace dg::tools {

// The phantom's ground truth of a registration (truth.h5, as `dynaguide phantom` writes it).
struct RegistrationTruth {
  Eigen::Matrix4d T_C_S;
  double phase_shift_s = 0, period_s = 0, fps = 0;
  // The fiducials' exact pixels (original, distorted) and visibility, per frame.
  stages::FiducialTracks tracks;
};

// Reads /T_C_S, /phase_shift_s, /period_s, /fps and /fiducials/{uv,visible}_{left,right}.
// @throws dg::Error naming the file and dataset when one is missing or malformed.
RegistrationTruth ReadRegistrationTruth(const std::string& truth_h5);

// The first `frames` frames of tracks (all if fewer).
stages::FiducialTracks FirstFrames(const stages::FiducialTracks& tracks, int frames);

// Simulated tracking: Gaussian noise of sigma_px on each coordinate, and a
// fraction of the sightings replaced by gross outliers (uniform in a square of
// `outlier_reach_px` around the true pixel, at least 20 px from it).
// Deterministic for a seed.
void CorruptTracks(stages::FiducialTracks* tracks, double sigma_px, double outlier_fraction, double outlier_reach_px,
                   std::uint64_t seed);

}  // namespace dg::tools
