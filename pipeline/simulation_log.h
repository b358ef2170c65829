#pragma once

#include <memory>
#include <vector>

#include "io/h5_table.h"
#include "io/run_log.h"
#include "pipeline/frame_packet.h"
#include "pipeline/simulation_stages.h"

namespace dg::pipeline {

// The run log's record of registration and simulation,
// a consumer of the run-log sink:
//   /registration  the registration (io::WriteRegistrationH5), written once,
//                  from the first frame that carries one; its attribute
//                  `frame` is that frame (-1 when the scene gave it);
//   /sim           one row per simulated frame: frame, t_s, step, substeps,
//                  frames_bridged (frame periods advanced: 1, or 1 + the
//                  frames dropped since the last simulated frame),
//                  kinetic_energy_j, min_jacobian, constrained_nodes,
//                  gated_features (tied features left out as outliers),
//                  residual_rms_mm, residual_max_mm, dt_over_dt_critical,
//                  motion_phase (the phase of the motion driving the inverse
//                  simulation at the frame's step, docs/phase.md) and
//                  sampled_nodes_S_m (3 per sampled node, scan frame, metres);
//                  /sim/sampled_node_ids names the sampled nodes.
class SimulationLog {
 public:
  // setup: null without a simulation (then no /sim). given: the scene's registration, or null.
  SimulationLog(io::RunLog& log, std::shared_ptr<const SimulationSetup> setup,
                std::shared_ptr<const io::Registration> given);

  void Consume(const FramePacket& packet);

  bool registered() const { return registration_ != nullptr; }
  // The registration the log holds (the scene's, or the register stage's); null before one.
  const std::shared_ptr<const io::Registration>& registration() const { return registration_; }
  std::int64_t simulated_frames() const { return sim_ ? static_cast<std::int64_t>(sim_->rows()) : 0; }

 private:
  io::RunLog& log_;
  io::H5Table* sim_ = nullptr;
  std::size_t sampled_ = 0;
  std::shared_ptr<const io::Registration> registration_;
};

}  // namespace dg::pipeline
