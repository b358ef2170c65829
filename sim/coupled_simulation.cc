#include "sim/coupled_simulation.h"

#include <algorithm>
#include <cmath>

#include "sim/error.h"
#include "sim/tled_kernel.h"

namespace dg::sim {
std::string CoupledOptions::Validate() const {
  if (std::string problem = solver.Validate(); !problem.empty()) return problem;
  if (solver.time_step_policy == TimeStepPolicy::kSubstep) {
    return "automatic substepping is not available with recovered forces (they change every step): "
           "choose dt below the stable limit";
  }
  if (!std::isfinite(phase_at_start)) return "phase_at_start must be finite";
  if (inverse_interval_steps < 1 || inverse_interval_steps > kMaxInverseIntervalSteps) {
    return "inverse_interval_steps must lie in [1, " + std::to_string(kMaxInverseIntervalSteps) + "]";
  }
  return {};
}

template <typename T>
CoupledSimulation<T>::CoupledSimulation(std::shared_ptr<const TledModel<T>> model,
                                        std::shared_ptr<const CyclicMotionModel> motion, std::vector<int> fixed_nodes,
                                        const CoupledOptions& options, const StabilityReport* stability)
    : model_(std::move(model)),
      motion_(std::move(motion)),
      options_(options),
      fixed_nodes_(std::move(fixed_nodes)),
      clock_(options.phase_at_start, motion_ ? options.solver.dt_s / motion_->period_s() : 0.0) {
  if (const std::string problem = options_.Validate(); !problem.empty()) {
    throw Error("invalid simulation options: " + problem, "coupled simulation options", "correct the option");
  }
  const int N = model_->num_nodes();
  if (has_inverse() && !motion_) {
    throw Error(ToString(options_.mode) + " mode needs the preoperative motion model", "simulation mode",
                "give the scene's preoperative motion, or use surface mode");
  }
  if (motion_ && motion_->dofs() != 3 * N) {
    throw Error("the motion model has " + std::to_string(motion_->dofs() / 3) + " nodes, the mesh " +
                    std::to_string(N),
                model_->mesh().source, "use the motion recorded for this mesh");
  }
  for (int a : fixed_nodes_) {
    if (a < 0 || a >= N) {
      throw Error("fixed node " + std::to_string(a) + " is out of range", model_->mesh().source,
                  "give node ids below " + std::to_string(N));
    }
  }
  std::vector<int> fixed_dofs;
  for (int a : fixed_nodes_) {
    for (int i = 0; i < 3; ++i) fixed_dofs.push_back(3 * a + i);
  }
  stability_ = stability ? *stability : EstimateStability(model_->mesh(), model_->material(), fixed_dofs);

  std::vector<double> u0(3 * size_t(N), 0.0), v0(3 * size_t(N), 0.0);
  if (motion_) {
    std::vector<double> before(u0.size());
    motion_->Evaluate<double>(motion_->PhaseAt(0.0, options_.phase_at_start), u0);
    motion_->Evaluate<double>(motion_->PhaseAt(-options_.solver.dt_s, options_.phase_at_start), before);
    for (size_t i = 0; i < u0.size(); ++i) v0[i] = (u0[i] - before[i]) / options_.solver.dt_s;
  }
  team_ = std::make_shared<StepTeam>(options_.solver.threads > 0 ? options_.solver.threads : DefaultTeamSize(),
                                     options_.solver.launch_helper);
  BuildSolver(u0, v0);

  if (has_inverse()) {
    // Every recovered force is resolved in the motion model's geometry: check
    // it at set-up, finely enough to catch a fold between scan phases.
    const ForceResolution<T> resolution(model_);
    std::vector<T> u(u0.size());
    const int samples = 4 * motion_->phases();
    for (int k = 0; k < samples; ++k) {
      const double phase = double(k) / samples;
      motion_->Evaluate<T>(phase, std::span<T>(u));
      resolution.CheckGeometry(u, "the motion model at phase " + std::to_string(phase));
    }
    inverse_ = std::make_unique<InverseSimulation<T>>(model_, motion_, options_.solver, options_.phase_at_start,
                                                      options_.inverse_interval_steps);
  }
}

template <typename T>
void CoupledSimulation<T>::BuildSolver(std::span<const double> u_m, std::span<const double> v_m_s) {
  BoundaryConditions conditions;
  for (int a : fixed_nodes_) {
    for (int i = 0; i < 3; ++i) conditions.fixed_dofs.push_back(3 * a + i);
  }
  for (int a : constrained_nodes_) {
    for (int i = 0; i < 3; ++i) conditions.prescribed_dofs.push_back(3 * a + i);
  }
  solver_ = std::make_unique<TledSolver<T>>(model_, std::move(conditions), options_.solver, &stability_, team_);
  DG_CHECK(solver_->substeps_per_step() == 1);  // kSubstep is refused
  solver_->SetState(u_m, v_m_s);
}

template <typename T>
void CoupledSimulation<T>::SetConstrainedNodes(std::vector<int> nodes) {
  std::sort(nodes.begin(), nodes.end());
  if (nodes == constrained_nodes_) return;
  for (int a : nodes) {
    if (a < 0 || a >= model_->num_nodes() || std::binary_search(fixed_nodes_.begin(), fixed_nodes_.end(), a)) {
      throw Error("node " + std::to_string(a) + " cannot be constrained: it is out of range or fixed",
                  "constrained nodes", "constrain free surface nodes only");
    }
  }
  // Carry the state over: U stays, U- = U - v dt with v the step's velocity.
  const std::span<const T> u = solver_->displacement(), u_prev = solver_->previous_displacement();
  std::vector<double> u_m(u.begin(), u.end()), v_m_s(u.size());
  for (size_t i = 0; i < u.size(); ++i) v_m_s[i] = (double(u[i]) - double(u_prev[i])) / options_.solver.dt_s;
  constrained_nodes_ = std::move(nodes);
  BuildSolver(u_m, v_m_s);
}

template <typename T>
void CoupledSimulation<T>::MotionAtStep(long long step, std::span<T> out) const {
  DG_CHECK(motion_ != nullptr);
  motion_->Evaluate<T>(phase_clock().PhaseAt(step), out);
}

template <typename T>
void CoupledSimulation<T>::SteerPhase(double phase, double rate_hz, double settle_s) {
  const double dt = options_.solver.dt_s;
  DG_CHECK(settle_s >= dt && rate_hz > 0);
  PhaseClock& clock = inverse_ ? inverse_->phase_clock() : clock_;
  long long from = steps_ + std::llround(kSteerLead_s / dt);
  if (inverse_) from = std::max(from, inverse_->newest_motion_step());
  const long long at = from + std::llround(settle_s / dt);
  const double rate_per_step = rate_hz * options_.solver.dt_s;
  clock.Steer(from, at, phase + rate_per_step * double(at - steps_), rate_per_step);
}

template <typename T>
ElementLoads<T> CoupledSimulation<T>::LoadsAtStep(long long step) const {
  const int k = options_.inverse_interval_steps;
  const long long level = step / k;
  const int within = static_cast<int>(step % k);
  return {inverse_->weights(level).data(), inverse_->weights(level + 1).data(), T(within) / T(k)};
}

template <typename T>
void CoupledSimulation<T>::AdvanceCoupled(int steps) {
  TledSolver<T>& solver = *solver_;
  InverseSimulation<T>& inverse = *inverse_;
  const int k = options_.inverse_interval_steps;
  // Step n needs levels n / k and n / k + 1; the step that starts a level's
  // interval computes the level after them.
  auto runs_inverse = [k](long long step) { return step % k == 0; };
  DG_CHECK(inverse.level() == steps_ / k + (runs_inverse(steps_) ? 1 : 2));
  DG_CHECK(solver.node_chunks() == inverse.node_chunks());
  solver.SetElementLoads(LoadsAtStep(steps_));
  const TledModel<T>& model = *model_;
  // Both sides share the forward solver's home ranges; the interleaved element
  // pass has two chunks (one a side) for each of the model's.
  const ChunkHomes& homes = solver.homes_;
  std::vector<int> both_sides_homes(homes.elements.size());
  for (size_t w = 0; w < homes.elements.size(); ++w) both_sides_homes[w] = 2 * homes.elements[w];
  StepTeam::ThenOrder both_sides_node_order = homes.node_order;
  for (int& needs : both_sides_node_order.needs) needs *= 2;
  // Each side's step is one pass of StepTeam::ForEachChunkThen: elements,
  // then nodes. Concurrent: one pass a step for both sides, their element
  // chunks interleaved (so that a worker's home range holds both sides'
  // elements of the same nodes), then both sides' nodes (one walk over each
  // node's incidences gathers both sides' forces, the sums GatherNodalForce
  // forms). Sequential: the forward side's pass, then the inverse side's.
  // A step without inverse work has the forward side's pass only (and an
  // empty one when sequential).
  const int passes_per_step = options_.concurrent ? 1 : 2;
  const long long first_step = steps_;
  auto pass = [&](int worker, int p) {
    const bool inverse_side_pass = p % passes_per_step == 1;  // sequential: the step's second pass
    const double fraction_end = double(p / passes_per_step + 1) / steps;
    const bool with_inverse = runs_inverse(first_step + p / passes_per_step);
    if (options_.concurrent && with_inverse) {
      team_->ForEachChunkThen(
          worker, both_sides_homes,
          [&](int c) {
            if (c % 2 == 0) {
              solver.RequestCutLines(worker, c / 2);
              solver.ElementChunk(c / 2);
            } else {
              inverse.ElementChunk(c / 2);
            }
          },
          homes.nodes,
          [&](int c) {
            const int begin = c * kNodesPerChunk, end = std::min(begin + kNodesPerChunk, model.num_nodes());
            T forward_forces[3 * kNodesPerChunk], inverse_forces[3 * kNodesPerChunk];
            for (int a = begin; a < end; ++a) {
              GatherNodalForces(model, solver.element_forces_.data(), inverse.element_forces_.data(), a,
                                &forward_forces[3 * (a - begin)], &inverse_forces[3 * (a - begin)]);
            }
            solver.NodeChunk(c, fraction_end, forward_forces);
            inverse.NodeChunk(c, inverse_forces);
          },
          both_sides_node_order);
    } else if (!inverse_side_pass) {
      team_->ForEachChunkThen(
          worker, homes.elements,
          [&](int c) {
            solver.RequestCutLines(worker, c);
            solver.ElementChunk(c);
          },
          homes.nodes,
          [&](int c) { solver.NodeChunk(c, fraction_end); }, homes.node_order);
    } else if (with_inverse) {
      team_->ForEachChunkThen(
          worker, homes.elements, [&](int c) { inverse.ElementChunk(c); }, homes.nodes,
          [&](int c) { inverse.NodeChunk(c); }, homes.node_order);
    }
  };
  // The step's end: the inverse side's checks, the next step's loads, the
  // forward side's reductions and checks.
  auto after = [&](int p) {
    if (p % passes_per_step == passes_per_step - 1) {
      if (runs_inverse(steps_)) inverse.Finish();
      solver.SetElementLoads(LoadsAtStep(steps_ + 1));
      solver.FinishStep();
      solver.CheckStep();
      ++steps_;
    }
    return true;
  };
  team_->Run(passes_per_step * steps, pass, after);
}

template <typename T>
void CoupledSimulation<T>::Advance(int steps, std::span<const double> targets_m) {
  const size_t count = 3 * constrained_nodes_.size();
  if (targets_m.size() != count) {
    throw Error("got " + std::to_string(targets_m.size()) + " target values for " +
                    std::to_string(constrained_nodes_.size()) + " constrained nodes",
                "coupled simulation, step " + std::to_string(steps_), "give 3 values per constrained node");
  }
  if (steps <= 0) return;
  if (!has_inverse()) {
    // The solver counts the steps it completed, also when it throws.
    const long long start = solver_->steps_taken();
    try {
      solver_->Advance(steps, targets_m);
    } catch (...) {
      steps_ += solver_->steps_taken() - start;
      throw;
    }
    steps_ += solver_->steps_taken() - start;
    return;
  }
  // Each constrained node moves linearly from its current displacement to its
  // target, reaching it at the last step.
  solver_->SetTargets(targets_m);
  AdvanceCoupled(steps);
}

template class CoupledSimulation<float>;
template class CoupledSimulation<double>;

}  // namespace dg::sim
