#include "pipeline/simulation_log.h"

#include "stages/fem_stage.h"
#include "stages/register/registration.h"

namespace dg::pipeline {

SimulationLog::SimulationLog(io::RunLog& log, std::shared_ptr<const SimulationSetup> setup,
                             std::shared_ptr<const io::Registration> given)
    : log_(log) {
  if (given) {
    io::WriteRegistrationH5(&log_.file(), "/registration", *given);
    log_.file().WriteAttribute("/registration", "frame", std::int64_t{-1});
    registration_ = given;
  }
  if (!setup) return;
  const std::vector<int> ids = stages::SampledNodeIds(setup->mesh.num_nodes(), setup->options.sampled_nodes);
  sampled_ = ids.size();
  using io::H5Type;
  sim_ = &log_.AddTable("/sim", {{"frame", H5Type::kInt64},
                                 {"t_s", H5Type::kDouble},
                                 {"step", H5Type::kInt64},
                                 {"substeps", H5Type::kInt32},
                                 {"frames_bridged", H5Type::kInt32},
                                 {"kinetic_energy_j", H5Type::kDouble},
                                 {"min_jacobian", H5Type::kDouble},
                                 {"constrained_nodes", H5Type::kInt32},
                                 {"gated_features", H5Type::kInt32},
                                 {"residual_rms_mm", H5Type::kDouble},
                                 {"residual_max_mm", H5Type::kDouble},
                                 {"dt_over_dt_critical", H5Type::kDouble},
                                 {"motion_phase", H5Type::kDouble},
                                 {"sampled_nodes_S_m", H5Type::kFloat, std::max<std::size_t>(1, 3 * sampled_)}});
  const std::vector<std::int32_t> ids32(ids.begin(), ids.end());
  log_.file().Write("/sim/sampled_node_ids", ids32.data(), {ids32.size()});
}

void SimulationLog::Consume(const FramePacket& packet) {
  if (packet.registration && !registration_) {
    if (packet.registration_solve) {
      stages::WriteRegistrationLog(*packet.registration_solve, &log_.file(), "/registration");
    } else {
      io::WriteRegistrationH5(&log_.file(), "/registration", *packet.registration);
    }
    log_.file().WriteAttribute("/registration", "frame", packet.index);
    registration_ = packet.registration;
  }
  if (!sim_ || !packet.simulation) return;
  const stages::FemFrameRecord& r = packet.simulation->record;
  static const float kNoSample = 0;  // a zero-width column is not allowed: one zero stands in
  const std::span<const float> sampled =
      sampled_ > 0 ? std::span<const float>(r.sampled_nodes_S_m) : std::span<const float>(&kNoSample, 1);
  sim_->AppendRow({packet.index, packet.t_s, std::int64_t{r.step}, std::int32_t{r.substeps},
                   std::int32_t{r.frames_bridged}, r.kinetic_energy_j,
                   r.min_jacobian, std::int32_t{r.constrained_nodes},
                   std::int32_t{r.gated_features}, r.constraint_residual_rms_mm,
                   r.constraint_residual_max_mm, r.dt_over_dt_critical, r.motion_phase, sampled});
}

}  // namespace dg::pipeline
