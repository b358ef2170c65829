#pragma once

#include <optional>
#include <string>
#include <vector>

#include "io/calibration.h"
#include "stages/register/fiducial_motion.h"
#include "stages/register/registration.h"
#include "stages/track/fiducial_tracker.h"
#include "stages/track/triangulator.h"

namespace dg::stages {

// A fiducial tracked in the rectified pair, in the original (distorted)
// pixels registration compares with: back through each eye's rectifying
// rotation and distortion model.
FiducialSighting SightingFromRectified(const FiducialObservation& observation, const Triangulator& geometry);

// A fiducial tracker started from the fiducials' pixels in the first left
// frame (original, distorted), searching stereo matches between the depths
// near_m and far_m. @throws dg::Error naming the fiducial whose pixel lies
// outside the calibrated field.
FiducialTracker StartFiducialTracker(const Triangulator& geometry, const std::vector<Eigen::Vector2d>& first_uv_left_px,
                                     double near_m, double far_m);

// Registration as a stage of the run: collects the fiducials' sightings frame
// by frame until the window (a whole number of cardiac periods) is full, then
// solves once and keeps the result for the stages downstream. Stateful:
// frames in order, one at a time; knows nothing of threads or the graph.
class RegistrationStage {
 public:
  struct Options {
    RegistrationOptions solver;
    double cycles = 3;  // the window's length in scan periods (the paper's "one or more complete cycles")
    std::string Validate() const;  // empty when valid
  };

  // @throws dg::Error for invalid options or motion, or a period that is not positive.
  RegistrationStage(const Options& options, FiducialMotion motion, io::StereoCalibration calibration, double period_s);

  // Adds one frame (video time t_s, one sighting per scan fiducial) while the
  // window is open; frames after it are ignored. Returns whether the window is
  // now complete. @throws dg::Error for a frame with another fiducial count.
  bool Process(double t_s, std::vector<FiducialSighting> sightings);

  bool window_complete() const { return complete_; }
  const FiducialTracks& window() const { return window_; }

  // Registers over the collected window on the first call; later calls return
  // the same result. @throws dg::Error as RegisterScanToVideo does (e.g. a
  // window shorter than one cycle when the video ended early).
  const RegistrationResult& Solve();

 private:
  Options options_;
  FiducialMotion motion_;
  io::StereoCalibration calibration_;
  double period_s_;
  FiducialTracks window_;
  bool complete_ = false;
  std::optional<RegistrationResult> result_;
};

}  // namespace dg::stages
