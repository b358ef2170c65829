#pragma once

#include <string>
#include <vector>

#include "io/calibration.h"
#include "stages/register/fiducial_motion.h"
#include "stages/register/fiducial_tracks.h"

namespace dg::stages {

// Which scan fiducial each tracked marker follows, found rather than trusted.
// A marker's track, averaged over the window (whole cardiac cycles), gives the
// marker's mean position; a scan fiducial's mean over the cycle is its mean
// position in the scan frame. Under the right assignment one camera pose maps
// the scan means onto the tracks' means. Every assignment (all F! of them, for
// kMinSearchedFiducials to kMaxSearchedFiducials fiducials) is ranked by a
// rigid fit to the triangulated means, and the best few are measured by the
// pose that fits them in the left image, in pixels. Timing does not enter:
// the phase shift is unknown here and need not be.
struct FiducialAssignment {
  static constexpr int kMinSearchedFiducials = 4;  // a pose from fewer is not unique (P3P)
  static constexpr int kMaxSearchedFiducials = 8;  // 8! = 40,320 rigid fits: milliseconds
  // A track departing from the pose the others fit by more than this times
  // the tolerance is beside its marker, however well the joint fit looks.
  static constexpr double kDepartureFactor = 2;

  enum class Verdict {
    kGiven,       // the order given fits (whether or not another fits too)
    kReassigned,  // the order given does not fit; exactly one other does
    kNoneFits,    // no order fits, or one track departs from the others: a track follows something beside its marker
    kAmbiguous,   // the order given does not fit; several others do (a symmetric layout)
  };
  Verdict verdict = Verdict::kGiven;
  std::vector<int> scan_of_track;         // track i follows scan fiducial scan_of_track[i]
  std::vector<double> track_residual_px;  // each track's image-fit residual under that assignment
  // ... and against the pose the other tracks fit (zeros for fewer than five tracks)
  std::vector<double> track_departure_px;
  double rms_px = 0;                      // their rms
  double given_rms_px = 0;                // the rms under the order given (track i is scan fiducial i)
  double runner_up_rms_px = 0;            // the best rms of another order (infinite when none was tried)
};

// Chooses the assignment; an image fit within tolerance_px (rms) explains the
// tracks. The assignment is the order given unless kReassigned; for
// kNoneFits and kAmbiguous, rms_px and the residuals are the best order's.
// With fewer than kMinSearchedFiducials the order given is kept unchecked.
// @pre tracks and motion have the same fiducial count, each track seen in
// both eyes in some frame (RegisterScanToVideo's input checks).
FiducialAssignment AssignFiducials(const FiducialMotion& motion, const io::StereoCalibration& calibration,
                                   const FiducialTracks& tracks, double tolerance_px);

// The tracks with track i moved to column scan_of_track[i] in every frame.
FiducialTracks Reordered(const FiducialTracks& tracks, const std::vector<int>& scan_of_track);

// "track 1 follows scan fiducial 3, track 3 follows 1": the assignment's
// departures from the order given.
std::string DescribeDepartures(const std::vector<int>& scan_of_track);

}  // namespace dg::stages
