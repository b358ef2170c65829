#pragma once

namespace dg::stages {

// The heart's current phase, as the video shows it (PhaseTracker).
struct PhaseEstimate {
  bool valid = false;
  double phase = 0;      // in the scan's cycle, [0, 1)
  double rate_hz = 0;    // cycles per second (60 rate_hz beats per minute)
  double sigma = 0;      // 1-sigma of phase, in cycles
  double amplitude = 1;  // the beat's size against the scan's cycle
};

}  // namespace dg::stages
