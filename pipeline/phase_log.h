#pragma once

#include <string>
#include <vector>

#include "io/h5_table.h"
#include "io/run_log.h"
#include "pipeline/frame_packet.h"

namespace dg::pipeline {

// The heart's live phase in the run log (docs/phase.md), a consumer of the
// run-log sink: /phase has one row per frame that carries an estimate:
//   frame, t_s;
//   phase      the estimate, in [0, 1) of the scan's cycle;
//   rate_bpm   its rate, beats per minute;
//   sigma      its 1-sigma, cycles;
//   amplitude  the beat's size against the scan's cycle;
//   registered_phase  the registration's constant-shift phase (t + lambda) / T, wrapped;
//   true_phase the phantom's true phase, from its truth (/cycles, /phase_shift_s),
//              when the scene has a truth; else the column is absent.
class PhaseLog {
 public:
  // truth_h5: the scene's truth, or empty.
  // @throws dg::Error for a truth without /cycles or /phase_shift_s.
  PhaseLog(io::RunLog& log, const std::string& truth_h5);

  void Consume(const FramePacket& packet);

 private:
  io::H5Table* table_ = nullptr;
  bool has_truth_ = false;
  double truth_phase_shift_s_ = 0;
  std::vector<double> cycle_starts_s_, cycle_periods_s_;
};

}  // namespace dg::pipeline
