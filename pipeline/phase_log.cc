#include "pipeline/phase_log.h"

#include <cmath>

#include "io/h5_file.h"
#include "io/registration_file.h"
#include "sim/error.h"
#include "stages/register/phase_tracker.h"

namespace dg::pipeline {

PhaseLog::PhaseLog(io::RunLog& log, const std::string& truth_h5) : has_truth_(!truth_h5.empty()) {
  using io::H5Type;
  std::vector<io::H5Column> columns = {{"frame", H5Type::kInt64},     {"t_s", H5Type::kDouble},
                                       {"phase", H5Type::kDouble},    {"rate_bpm", H5Type::kDouble},
                                       {"sigma", H5Type::kDouble},    {"amplitude", H5Type::kDouble},
                                       {"registered_phase", H5Type::kDouble}};
  if (has_truth_) {
    const io::H5Reader truth(truth_h5);
    io::H5Shape shape;
    cycle_starts_s_ = truth.Read<double>("/cycles/start_s", &shape);
    cycle_periods_s_ = truth.Read<double>("/cycles/period_s", &shape);
    truth_phase_shift_s_ = truth.ReadScalar("/phase_shift_s");
    if (cycle_starts_s_.empty() || cycle_starts_s_.size() != cycle_periods_s_.size()) {
      throw Error("the truth's /cycles/start_s and /cycles/period_s differ in length or are empty", truth_h5,
                  "regenerate the phantom with `dynaguide phantom`");
    }
    columns.push_back({"true_phase", H5Type::kDouble});
  }
  table_ = &log.AddTable("/phase", std::move(columns));
}

void PhaseLog::Consume(const FramePacket& packet) {
  if (!packet.phase.valid || !packet.registration) return;
  const stages::PhaseEstimate& phase = packet.phase;
  const double registered = (packet.t_s + packet.registration->phase_shift_s) / packet.registration->period_s;
  const double registered_wrapped = registered - std::floor(registered);
  if (has_truth_) {
    const double truth = stages::CyclePhase(cycle_starts_s_, cycle_periods_s_, packet.t_s + truth_phase_shift_s_);
    table_->AppendRow({packet.index, packet.t_s, phase.phase, 60 * phase.rate_hz, phase.sigma, phase.amplitude,
                       registered_wrapped, truth});
  } else {
    table_->AppendRow({packet.index, packet.t_s, phase.phase, 60 * phase.rate_hz, phase.sigma, phase.amplitude,
                       registered_wrapped});
  }
}

}  // namespace dg::pipeline
