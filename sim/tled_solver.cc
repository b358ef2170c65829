#include "sim/tled_solver.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include <Eigen/LU>

#include "sim/element_measures.h"
#include "sim/error.h"
#include "sim/log.h"
#include "sim/tled_kernel.h"

namespace dg::sim {
namespace {

// Work is split into the model's fixed chunks (of blocks and of nodes) so that
// every partial result (minimum J, kinetic energy) is summed in the same order
// whatever the thread count; a StepTeam hands the chunks out.

std::string Milliseconds(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g ms", seconds * 1e3);
  return text;
}

std::string Fraction(double value) {
  char text[16];
  std::snprintf(text, sizeof text, "%.2f", value);
  return text;
}

std::string StepWhere(long long step, double time_s) {
  char text[64];
  std::snprintf(text, sizeof text, "step %lld, t = %.6g s", step, time_s);
  return text;
}

}  // namespace

std::string SolverOptions::Validate() const {
  if (!std::isfinite(dt_s) || dt_s <= 0) return "dt_s must be positive (the paper uses 2e-4 s)";
  if (!std::isfinite(damping_per_s) || damping_per_s < 0) {
    return "damping_per_s (alpha) must be zero or positive (the paper uses 75 /s)";
  }
  if (damping_per_s * dt_s >= 2.0) return "alpha * dt must be below 2 for the update to be stable";
  if (!gravity_m_s2.allFinite()) return "gravity must be finite";
  if (!(stability_safety >= 0 && stability_safety <= 1)) {
    return "stability_safety must lie in (0, 1], or be 0 for the material's default";
  }
  if (threads < 0) return "threads must be 0 (the process's parallelism) or positive";
  if (energy_window_steps < 1 || !(energy_growth_limit > 1)) {
    return "energy_window_steps must be >= 1 and energy_growth_limit > 1";
  }
  return {};
}

template <typename T>
TledSolver<T>::TledSolver(std::shared_ptr<const TledModel<T>> model, BoundaryConditions conditions,
                          const SolverOptions& options, const StabilityReport* stability,
                          std::shared_ptr<StepTeam> team)
    : model_(std::move(model)), conditions_(std::move(conditions)), options_(options), team_(std::move(team)) {
  if (!team_) {
    team_ = std::make_shared<StepTeam>(options_.threads > 0 ? options_.threads : DefaultTeamSize(),
                                       options_.launch_helper);
  }
  homes_ = PartitionChunks(*model_, team_->size());
  levels_.resize(model_->parts());
  for (int p = 0; p < model_->parts(); ++p) {
    element_chunk_part_.insert(element_chunk_part_.end(),
                               model_->part_chunk_begin()[p + 1] - model_->part_chunk_begin()[p], p);
  }
  if (const std::string problem = options_.Validate(); !problem.empty()) {
    throw Error("invalid solver options: " + problem, "solver options", "correct the option");
  }
  const int n_dofs = 3 * model_->num_nodes();
  dof_kind_.assign(n_dofs, -1);
  for (int dof : conditions_.fixed_dofs) {
    if (dof < 0 || dof >= n_dofs) {
      throw Error("fixed degree of freedom " + std::to_string(dof) + " is out of range", model_->mesh().source,
                  "degrees of freedom are 3 * node + axis for the mesh's " +
                      std::to_string(model_->num_nodes()) + " nodes");
    }
    dof_kind_[LayoutDof(dof)] = -2;
  }
  for (size_t k = 0; k < conditions_.prescribed_dofs.size(); ++k) {
    const int dof = conditions_.prescribed_dofs[k];
    if (dof < 0 || dof >= n_dofs) {
      throw Error("prescribed degree of freedom " + std::to_string(dof) + " is out of range",
                  model_->mesh().source, "degrees of freedom are 3 * node + axis");
    }
    if (dof_kind_[LayoutDof(dof)] != -1) {
      throw Error("degree of freedom " + std::to_string(dof) + " (node " + std::to_string(dof / 3) +
                      ") is both fixed and prescribed, or prescribed twice",
                  "boundary conditions", "give each degree of freedom at most one condition");
    }
    dof_kind_[LayoutDof(dof)] = static_cast<int>(k);
    prescribed_layout_dofs_.push_back(LayoutDof(dof));
  }
  target_begin_.assign(conditions_.prescribed_dofs.size(), 0.0);
  for (int dof = 0; dof < n_dofs; ++dof) {
    if (dof_kind_[dof] != -1) constrained_dofs_.push_back(dof);
  }
  target_end_.assign(conditions_.prescribed_dofs.size(), 0.0);

  if (stability) {
    stability_ = *stability;
  } else {
    std::vector<int> constrained = conditions_.fixed_dofs;
    constrained.insert(constrained.end(), conditions_.prescribed_dofs.begin(),
                       conditions_.prescribed_dofs.end());
    stability_ = EstimateStability(model_->mesh(), model_->material(), constrained);
  }
  safety_ = options_.stability_safety > 0 ? options_.stability_safety
                                          : DefaultStabilitySafety(model_->material().poissons_ratio);
  const double safe_dt = safety_ * stability_.dt_critical_s;
  if (options_.dt_s > safe_dt) {
    switch (options_.time_step_policy) {
      case TimeStepPolicy::kRefuse:
        throw Error(stability_.TimeStepExcess(options_.dt_s, safety_), model_->mesh().source,
                    "use dt <= " + Milliseconds(safe_dt) +
                        ", a coarser or better-shaped mesh near the limiting node, or automatic substepping");
      case TimeStepPolicy::kSubstep:
        substeps_ = static_cast<int>(std::ceil(options_.dt_s / safe_dt));
        Logger("sim").info("time step {} split into {} substeps: {}", Milliseconds(options_.dt_s), substeps_,
                           stability_.Describe());
        break;
      case TimeStepPolicy::kUnchecked:
        Logger("sim").warn("time step {} is above the safe limit {}; running unchecked",
                           Milliseconds(options_.dt_s), Milliseconds(safe_dt));
        break;
    }
  }

  const double dt = internal_dt_s();
  const double A = 2.0 / (2.0 + options_.damping_per_s * dt);
  increment_decay_ = static_cast<T>((2.0 - options_.damping_per_s * dt) / (2.0 + options_.damping_per_s * dt));
  free_mass_.resize(n_dofs);
  for (int dof = 0; dof < n_dofs; ++dof) {
    free_mass_[dof] = dof_kind_[dof] == -1 ? static_cast<T>(model_->lumped_mass_kg()[dof / 3]) : T(0);
  }
  force_gain_.resize(model_->num_nodes());
  for (int a = 0; a < model_->num_nodes(); ++a) {
    force_gain_[a] = static_cast<T>(A * dt * dt / model_->lumped_mass_kg()[a]);
  }
  for (int i = 0; i < 3; ++i) gravity_term_[i] = static_cast<T>(A * dt * dt * options_.gravity_m_s2[i]);

  for (PartLevels& part : levels_) {
    part.u_prev.assign(n_dofs, T(0));
    part.u.assign(n_dofs, T(0));
    part.u_next.assign(n_dofs, T(0));
  }
  element_forces_.assign(model_->force_array_size(), T(0));
  external_force_.assign(n_dofs, T(0));
  internal_force_.assign(n_dofs, T(0));
  for (std::vector<T>& reaction : reaction_) reaction.assign(n_dofs, T(0));
  chunk_min_J_.assign(size_t(kFreeSteps) * model_->element_chunks(), T(1));
  chunk_kinetic_.assign(size_t(kFreeSteps) * NodeChunks(*model_), 0.0);
  for (int c = 0; c <= NodeChunks(*model_); ++c) {
    const int first_dof = 3 * std::min(c * kNodesPerChunk, model_->num_nodes());
    chunk_constrained_begin_.push_back(static_cast<int>(
        std::lower_bound(constrained_dofs_.begin(), constrained_dofs_.end(), first_dof) - constrained_dofs_.begin()));
  }
  ListCutCopies();
  ListWaitChunks();
  progress_ = std::make_unique<FreeProgress>(model_->parts());
  PinRing();
  energy_history_.assign(2 * options_.energy_window_steps + 1, 0.0);
}

template <typename T>
void TledSolver<T>::SetExternalForces(std::span<const double> forces_n) {
  if (forces_n.size() != external_force_.size()) {
    throw Error("external force vector has " + std::to_string(forces_n.size()) + " entries, expected " +
                    std::to_string(external_force_.size()),
                "external forces", "give 3 components per node");
  }
  for (size_t i = 0; i < forces_n.size(); ++i) {
    if (!std::isfinite(forces_n[i])) {
      throw Error("external force is not finite", "node " + std::to_string(i / 3) + ", axis " +
                      std::to_string(i % 3), "check the load that produced it");
    }
  }
  model_->ToLayout(forces_n, std::span<T>(external_force_));
}

template <typename T>
void TledSolver<T>::SetState(std::span<const double> u_m, std::span<const double> v_m_s) {
  const size_t n_dofs = 3 * size_t(model_->num_nodes());
  if (u_m.size() != n_dofs || v_m_s.size() != n_dofs) {
    throw Error("initial state has " + std::to_string(u_m.size()) + " displacements and " +
                    std::to_string(v_m_s.size()) + " velocities, expected " + std::to_string(n_dofs),
                "initial state", "give 3 components per node");
  }
  const double dt = internal_dt_s();
  std::vector<double> before(u_m.size());
  for (size_t i = 0; i < u_m.size(); ++i) {
    if (!std::isfinite(u_m[i]) || !std::isfinite(v_m_s[i])) {
      throw Error("initial state is not finite", "node " + std::to_string(i / 3), "check its source");
    }
    before[i] = u_m[i] - v_m_s[i] * dt;
  }
  // Every part holds the whole state: its own nodes and its halo.
  for (PartLevels& part : levels_) {
    model_->ToLayout(u_m, std::span<T>(part.u));
    model_->ToLayout(std::span<const double>(before), std::span<T>(part.u_prev));
  }
  ++state_version_;
}

template <typename T>
void TledSolver<T>::SetTargets(std::span<const double> targets_m) {
  if (targets_m.size() != target_end_.size()) {
    throw Error("got " + std::to_string(targets_m.size()) + " prescribed targets for " +
                    std::to_string(target_end_.size()) + " prescribed degrees of freedom",
                StepWhere(internal_steps_, time_s()), "give one target per prescribed degree of freedom");
  }
  for (size_t k = 0; k < targets_m.size(); ++k) {
    if (!std::isfinite(targets_m[k])) {
      const int dof = conditions_.prescribed_dofs[k];
      throw Error("prescribed displacement is not finite",
                  "node " + std::to_string(dof / 3) + ", axis " + std::to_string(dof % 3) + ", " +
                      StepWhere(internal_steps_, time_s()),
                  "check the source of the prescribed motion");
    }
  }
  for (size_t k = 0; k < targets_m.size(); ++k) {
    target_begin_[k] = OwnerOf(prescribed_layout_dofs_[k]).u[prescribed_layout_dofs_[k]];
    target_end_[k] = targets_m[k];
  }
}

template <typename T>
void TledSolver<T>::Advance(int steps, std::span<const double> targets_m) {
  SetTargets(targets_m);
  const int total = steps * substeps_;
  if (RunsFree()) {
    AdvanceFree(total);
    return;
  }
  // One pass a step: elements, then nodes, whose serial end finishes and
  // checks the step.
  team_->Run(
      total,
      [&](int worker, int step) {
        const double fraction_end = double(step + 1) / total;
        team_->ForEachChunkThen(
            worker, homes_.elements,
            [&](int c) {
              RequestCutLines(worker, c);
              ElementChunk(c);
            },
            homes_.nodes,
            [&](int c) { NodeChunk(c, fraction_end); }, homes_.node_order);
      },
      [&](int) {
        FinishStep();
        CheckStep();
        return true;
      });
}

template <typename T>
void TledSolver<T>::RequestCutLines(int worker, int chunk) const {
  // Only where worker w runs part w (the team's size is the model's parts).
  if (!homes_.node_order.per_range || worker >= model_->parts()) return;
  const int own_begin = homes_.elements[worker], own_end = homes_.elements[worker + 1];
  const int slices = std::min(kCutRequestSlices, own_end - own_begin);
  const int slice = chunk - own_begin;
  if (slice < 0 || slice >= slices) return;
  // A slice of each list before each of the worker's first chunks: asked for
  // all at once, some hundred lines at the far latency held up the pass's
  // start (docs/solver.md, "Subdomains").
  auto part_of = [&](auto lines) {
    return lines.subspan(lines.size() * slice / slices,
                         lines.size() * (slice + 1) / slices - lines.size() * slice / slices);
  };
  // The other cores copied these displacements into the part's level at the
  // end of the last step; the part's halo, at the end of its element pass,
  // reads them. Asked for now, they cross while the interior is computed.
  const T* u = levels_[worker].u.data();
  for (int32_t line : part_of(model_->halo_lines(worker))) __builtin_prefetch(u + line, 0, 3);
  // The other parts read these lines of their next level two steps ago; taking
  // them for writing now keeps the node pass's copies from waiting on the
  // invalidations. Nobody reads that level during this step.
  const int first_node_chunk = model_->part_node_begin()[worker] / kNodesPerChunk;
  const int end_node_chunk = model_->part_node_begin()[worker + 1] / kNodesPerChunk;
  const std::span<const CutCopy> copies(cut_copies_.data() + chunk_copies_begin_[first_node_chunk],
                                        cut_copies_.data() + chunk_copies_begin_[end_node_chunk]);
  for (const CutCopy& copy : part_of(copies)) {
    __builtin_prefetch(levels_[copy.part].u_next.data() + copy.offset, 1, 3);
  }
}

template <typename T>
void TledSolver<T>::ElementChunk(int chunk, int ahead) {
  chunk_min_J_[size_t(ahead % kFreeSteps) * element_chunks() + chunk] =
      ChunkElementForces(chunk, RingLevel(element_chunk_part_[chunk], ahead, 1));
}

template <typename T>
T TledSolver<T>::ChunkElementForces(int chunk, const T* u) {
  const int begin = model_->chunk_block_begin(chunk), end = model_->chunk_block_begin(chunk + 1);
  return element_loads_.first
             ? ComputeElementForcesLessLoads(*model_, u, element_loads_, element_forces_.data(), begin, end)
             : ComputeElementForces(*model_, u, element_forces_.data(), begin, end);
}

template <typename T>
void TledSolver<T>::NodeChunk(int chunk, double fraction_end, const T* gathered, int ahead) {
  // Gather (unless given) and central-difference update of every dof as if
  // free, with the kinetic energy of the free dofs (sum of m v^2, scaled in FinishStep).
  const TledModel<T>& model = *model_;
  const int begin = chunk * kNodesPerChunk;
  const int end = std::min(begin + kNodesPerChunk, model.num_nodes());
  const int part = node_chunk_part_[chunk];
  const T* u = RingLevel(part, ahead, 1);
  const T* u_prev = RingLevel(part, ahead, 0);
  T* u_next = RingLevel(part, ahead, 2);
  T* internal_force = internal_force_.data();
  T* reaction = reaction_[StepEntry(ahead)].data();
  T own[3 * kNodesPerChunk];
  gathered = ChunkNodalForces(model, element_forces_.data(), begin, end, gathered, own);
  double twice_kinetic = 0;
  for (int a = begin; a < end; ++a) {
    const T* f = &gathered[3 * (a - begin)];
    T m_v2 = 0;
    for (int i = 0; i < 3; ++i) {
      const int dof = 3 * a + i;
      internal_force[dof] = f[i];
      const T next = u[dof] + force_gain_[a] * (external_force_[dof] - f[i]) + gravity_term_[i] +
                     increment_decay_ * (u[dof] - u_prev[dof]);
      u_next[dof] = next;
      const T v = next - u_prev[dof];
      m_v2 += free_mass_[dof] * v * v;
    }
    twice_kinetic += m_v2;
  }
  // The chunk's constrained dofs (few): overwrite, then the support's reaction
  // M a + alpha M v + F - R and their kinetic energy.
  const double dt = internal_dt_s();
  const double inv_dt2 = 1.0 / (dt * dt);
  const double inv_2dt = 0.5 / dt;
  const double alpha = options_.damping_per_s;
  const double* mass = model.lumped_mass_kg().data();
  for (int k = chunk_constrained_begin_[chunk]; k < chunk_constrained_begin_[chunk + 1]; ++k) {
    const int dof = constrained_dofs_[k];
    const int kind = dof_kind_[dof];
    const double next =
        kind == -2 ? 0.0 : target_begin_[kind] + fraction_end * (target_end_[kind] - target_begin_[kind]);
    u_next[dof] = static_cast<T>(next);
    const double acceleration = (next - 2.0 * u[dof] + u_prev[dof]) * inv_dt2;
    const double velocity = (next - u_prev[dof]) * inv_2dt;
    const int a = dof / 3;
    reaction[dof] = static_cast<T>(mass[a] * (acceleration + alpha * velocity - options_.gravity_m_s2[dof % 3]) +
                                   internal_force[dof] - external_force_[dof]);
    const double v = next - u_prev[dof];
    twice_kinetic += mass[a] * v * v;
  }
  chunk_kinetic_[size_t(ahead % kFreeSteps) * node_chunks() + chunk] = twice_kinetic;
  // The chunk's lines other parts read, now final, into their next levels.
  // A whole line is one fixed-size copy (a register), not a call.
  const int values = 3 * model.num_nodes();
  for (int k = chunk_copies_begin_[chunk]; k < chunk_copies_begin_[chunk + 1]; ++k) {
    const CutCopy& copy = cut_copies_[k];
    T* to = RingLevel(copy.part, ahead, 2) + copy.offset;
    if (copy.offset + kLineValues <= values) {
      std::memcpy(to, u_next + copy.offset, 64);
    } else {
      std::copy(u_next + copy.offset, u_next + values, to);
    }
  }
}

template <typename T>
void TledSolver<T>::FinishStep() {
  kinetic_energy_j_ = KineticEnergy(0);
  for (PartLevels& part : levels_) {
    std::swap(part.u_prev, part.u);
    std::swap(part.u, part.u_next);
  }
  PinRing();
  ++internal_steps_;
  ++state_version_;
}

template <typename T>
double TledSolver<T>::KineticEnergy(int row) const {
  const double inv_2dt = 0.5 / internal_dt_s();
  double energy = 0;
  const auto begin = chunk_kinetic_.begin() + size_t(row) * node_chunks();
  for (auto k = begin; k != begin + node_chunks(); ++k) energy += 0.5 * inv_2dt * inv_2dt * *k;
  return energy;
}

template <typename T>
void TledSolver<T>::CheckStep(int row) {
  // The forces just computed belong to the state before this step: J is the
  // step's starting shape, and the energy its velocity.
  const auto row_J = chunk_min_J_.begin() + size_t(row) * element_chunks();
  min_J_ = *std::min_element(row_J, row_J + element_chunks());

  energy_history_[internal_steps_ % energy_history_.size()] = kinetic_energy_j_;
  const bool blowing_up = EnergyBlowingUp();
  if (!std::isfinite(kinetic_energy_j_) || blowing_up) {
    // Name the node moving fastest: where the instability (or the bad value) sits.
    const std::vector<T> u = LevelInLayoutOrder(&PartLevels::u), u_prev = LevelInLayoutOrder(&PartLevels::u_prev);
    int worst = 0;
    double worst_speed = -1;
    for (int a = 0; a < model_->num_nodes(); ++a) {
      double speed = 0;
      for (int i = 0; i < 3; ++i) {
        const double v = double(u[3 * a + i]) - double(u_prev[3 * a + i]);
        speed += v * v;
      }
      if (!std::isfinite(speed)) speed = std::numeric_limits<double>::infinity();
      if (speed > worst_speed) {
        worst_speed = speed;
        worst = a;
      }
    }
    const Eigen::Vector3d x = model_->layout_mesh().X_m.col(worst) * 1e3;
    char where[160];
    std::snprintf(where, sizeof where, "node %d at (%.2f, %.2f, %.2f) mm, %s", model_->mesh_node(worst), x.x(),
                  x.y(), x.z(),
                  StepWhere(internal_steps_, time_s()).c_str());
    const std::string what = std::isfinite(kinetic_energy_j_)
                                 ? "numerical blow-up: kinetic energy grew more than " +
                                       std::to_string(options_.energy_growth_limit) + "x in each of the last two " +
                                       std::to_string(options_.energy_window_steps) + "-step windows"
                                 : "non-finite displacement or velocity";
    throw Error(what, where,
                "reduce dt below " + Milliseconds(safety_ * stability_.dt_critical_s) +
                    " (" + stability_.Describe() + "), or check the loads for NaN");
  }
  // The forces that reported it were computed at the level now the previous one.
  if (!(min_J_ > 0)) ThrowInversion(LevelInLayoutOrder(&PartLevels::u_prev).data(), internal_steps_ - 1);
}

template <typename T>
bool TledSolver<T>::EnergyBlowingUp() const {
  const int W = options_.energy_window_steps;
  if (internal_steps_ < 2 * W) return false;
  const size_t ring = energy_history_.size();
  const double now = energy_history_[internal_steps_ % ring];
  const double one_window_ago = energy_history_[(internal_steps_ - W) % ring];
  const double two_windows_ago = energy_history_[(internal_steps_ - 2 * W) % ring];
  const double G = options_.energy_growth_limit;
  return two_windows_ago > 0 && one_window_ago > G * two_windows_ago && now > G * one_window_ago;
}

template <typename T>
void TledSolver<T>::CheckCurrentState() const {
  const TetMesh& mesh = model_->layout_mesh();
  const std::vector<T> u = LevelInLayoutOrder(&PartLevels::u);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    if (!(DeformationGradient(mesh, e, u.data()).determinant() > 0)) ThrowInversion(u.data(), internal_steps_);
  }
}

template <typename T>
void TledSolver<T>::ThrowInversion(const T* u, long long step) const {
  // Rare path: name the most inverted element (smallest J, in double).
  const TetMesh& mesh = model_->layout_mesh();
  int worst = 0;
  double worst_J = std::numeric_limits<double>::infinity();
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const double J = DeformationGradient(mesh, e, u).determinant();
    if (!(J >= worst_J)) {
      worst_J = J;
      worst = e;
    }
  }
  Eigen::Vector3d centroid_mm = Eigen::Vector3d::Zero();
  for (int c = 0; c < 4; ++c) centroid_mm += mesh.X_m.col(mesh.tets(c, worst)) * (1e3 / 4.0);
  char at[160];
  std::snprintf(at, sizeof at, " (J = %.3g) at (%.2f, %.2f, %.2f) mm, %s", worst_J, centroid_mm.x(), centroid_mm.y(),
                centroid_mm.z(), StepWhere(step, double(step) * internal_dt_s()).c_str());
  const std::string where = ElementName(mesh, worst) + at;
  const double dt = internal_dt_s(), safe_dt = safety_ * stability_.dt_critical_s;
  if (dt > safe_dt) {
    // Run unchecked above the limit: the inversion is the scheme diverging, not the load.
    throw Error("inverted element: the time step " + Milliseconds(dt) + " is above the stability limit (" +
                    Fraction(safety_) + " x the " + stability_.Describe() + "), and the solution diverged",
                where, "reduce dt below " + Milliseconds(safe_dt) + ", or let the solver substep (time_step_policy: substep)");
  }
  throw Error("inverted element", where,
              "the imposed deformation crushes the mesh: reduce the prescribed displacement or load, refine "
              "the mesh there, or check the boundary conditions");
}

template <typename T>
bool TledSolver<T>::RunsFree() const {
  return model_->parts() > 1 && team_->size() == model_->parts() && homes_.node_order.per_range;
}

template <typename T>
void TledSolver<T>::AdvanceFree(int total) {
  // Each pass: up to kFreeSteps steps, each worker stepping its own part and
  // worker 0 also those of workers not in the run, one step of each in turn
  // (a part waits for the others' last step, so one worker runs them in
  // step order). The pass's serial end checks its steps.
  for (auto& done : progress_->done) done.value.store(internal_steps_ - 1, std::memory_order_relaxed);
  progress_->stopped_at.value.store(std::numeric_limits<long long>::max(), std::memory_order_relaxed);
  // Passes of 1, 2, 4, ... steps up to kFreeSteps: the team's helpers join
  // at a barrier, and until then worker 0 steps every part. Pass p starts
  // at step 2^p - 1 while the passes double, then every kFreeSteps.
  static_assert((kFreeSteps & (kFreeSteps - 1)) == 0, "the passes double up to kFreeSteps");
  constexpr int kDoublings = std::countr_zero(unsigned(kFreeSteps));
  auto first_of = [&](int pass) {
    const long long first = pass <= kDoublings ? (1LL << pass) - 1
                                               : kFreeSteps - 1 + (long long)(pass - kDoublings) * kFreeSteps;
    return static_cast<int>(std::min<long long>(first, total));
  };
  auto steps_of = [&](int pass) { return first_of(pass + 1) - first_of(pass); };
  int passes = 0;
  while (first_of(passes) < total) ++passes;
  team_->Run(
      passes,
      [&](int worker, int pass) {
        int parts[StepTeam::kMaxWorkers];
        int count = 0;
        parts[count++] = worker;
        for (int p = 1; worker == 0 && p < model_->parts(); ++p) {
          if (!team_->Working(p)) parts[count++] = p;
        }
        const int first = first_of(pass), steps = steps_of(pass);
        for (int ahead = 0; ahead < steps; ++ahead) {
          const double fraction_end = double(first + ahead + 1) / total;
          for (int k = 0; k < count; ++k) {
            if (!FreeStep(parts[k], ahead, fraction_end)) return;
          }
        }
      },
      [&](int pass) {
        FinishFreeSteps(steps_of(pass));
        return true;
      });
}

template <typename T>
bool TledSolver<T>::FreeStep(int part, int ahead, double fraction_end) {
  const long long step = internal_steps_ + ahead;
  std::atomic<long long>& stopped_at = progress_->stopped_at.value;
  auto stopped_before = [&] { return stopped_at.load(std::memory_order_acquire) < step; };
  if (stopped_before()) return false;
  const std::vector<int>& order = homes_.node_order.order;
  const std::vector<int>& needs = homes_.node_order.needs;
  const int first = homes_.elements[part], end = homes_.elements[part + 1];
  int next = homes_.nodes[part];
  const int node_end = homes_.nodes[part + 1];
  for (int c = first; c < end; ++c) {
    if (c == wait_chunk_[part]) {
      // The other parts' last step: the lines of this part's halo they
      // copied, and the end of their reading of what this step writes.
      for (int other = 0; other < model_->parts(); ++other) {
        if (other == part) continue;
        for (int waits = 0; progress_->done[other].value.load(std::memory_order_acquire) < step - 1; ++waits) {
          if (stopped_before()) return false;
          StepTeam::Backoff(waits);
        }
      }
      if (stopped_before()) return false;
    }
    if (c == first) {
      // The halo's lines, which the other core copied in its last step: asked
      // for now, they cross while the interior is computed. (The copy
      // targets are not asked for early, as RequestCutLines does between
      // barriers: the other core may still be reading those lines.)
      const T* u = RingLevel(part, ahead, 1);
      for (int32_t line : model_->halo_lines(part)) __builtin_prefetch(u + line, 0, 3);
    }
    ElementChunk(c, ahead);
    for (; next < node_end && needs[next] <= c + 1 - first; ++next) NodeChunk(order[next], fraction_end, nullptr, ahead);
  }
  for (; next < node_end; ++next) NodeChunk(order[next], fraction_end, nullptr, ahead);
  // An inverted element or a non-finite state stops every part after this
  // step, as CheckStep would: a part that sees it says so before it says
  // the step is done, so no other part goes past it.
  const size_t row = ahead % kFreeSteps;
  const auto J = chunk_min_J_.begin() + row * element_chunks();
  const T min_J = *std::min_element(J + first, J + end);
  double kinetic = 0;
  for (int k = homes_.nodes[part]; k < node_end; ++k) kinetic += chunk_kinetic_[row * node_chunks() + order[k]];
  if (!(min_J > 0) || !std::isfinite(kinetic)) {
    long long stopped = stopped_at.load(std::memory_order_relaxed);
    while (step < stopped && !stopped_at.compare_exchange_weak(stopped, step, std::memory_order_release)) {
    }
  }
  progress_->done[part].value.store(step, std::memory_order_release);
  return true;
}

template <typename T>
void TledSolver<T>::FinishFreeSteps(int steps) {
  const long long stopped = progress_->stopped_at.value.load(std::memory_order_acquire);
  const int completed = stopped < internal_steps_ + steps ? static_cast<int>(stopped - internal_steps_ + 1) : steps;
  // The parts' arrays named for the state after the last completed step;
  // then each step's reductions and checks, in order.
  for (size_t p = 0; p < levels_.size(); ++p) {
    PartLevels& part = levels_[p];
    std::array<AlignedVector<T>, 3> ring = {std::move(part.u_prev), std::move(part.u), std::move(part.u_next)};
    part.u_prev = std::move(ring[completed % 3]);
    part.u = std::move(ring[(completed + 1) % 3]);
    part.u_next = std::move(ring[(completed + 2) % 3]);
  }
  PinRing();
  const long long first_step = internal_steps_;
  ++state_version_;
  try {
    for (int k = 0; k < completed; ++k) {
      kinetic_energy_j_ = KineticEnergy(k);
      internal_steps_ = first_step + k + 1;
      CheckStep(k);
    }
  } catch (...) {
    // Named at the step it found; the state is the last completed step's.
    internal_steps_ = first_step + completed;
    if (completed < steps) RecomputeInternalForces();
    throw;
  }
  // A stop comes from a step CheckStep throws for.
  DG_CHECK(completed == steps);
}

template <typename T>
void TledSolver<T>::RecomputeInternalForces() {
  for (int c = 0; c < element_chunks(); ++c) ChunkElementForces(c, levels_[element_chunk_part_[c]].u_prev.data());
  for (int a = 0; a < model_->num_nodes(); ++a) GatherNodalForce(*model_, element_forces_.data(), a, &internal_force_[3 * a]);
}

template <typename T>
void TledSolver<T>::PinRing() {
  ring_.resize(levels_.size());
  for (size_t p = 0; p < levels_.size(); ++p) {
    ring_[p] = {levels_[p].u_prev.data(), levels_[p].u.data(), levels_[p].u_next.data()};
  }
}

template <typename T>
void TledSolver<T>::ListWaitChunks() {
  // A part's halo comes last (TledModel): its first chunk with a node of
  // another part, or else its last chunk, so that every part waits once a step.
  constexpr int W = TledModel<T>::kLanes;
  wait_chunk_.assign(model_->parts(), 0);
  for (int p = 0; p < model_->parts(); ++p) {
    const int node_begin = model_->part_node_begin()[p], node_end = model_->part_node_begin()[p + 1];
    const int first = model_->part_chunk_begin()[p], end = model_->part_chunk_begin()[p + 1];
    int c = first;
    for (; c < end; ++c) {
      bool reads_others = false;
      for (int b = model_->chunk_block_begin(c); b < model_->chunk_block_begin(c + 1) && !reads_others; ++b) {
        const int32_t* nodes = model_->block_nodes(b);
        for (int k = 0; k < 4 * W; ++k) reads_others |= nodes[k] < node_begin || nodes[k] >= node_end;
      }
      if (reads_others) break;
    }
    wait_chunk_[p] = std::min(c, end - 1);
  }
}

template <typename T>
void TledSolver<T>::ListCutCopies() {
  // Part p's halo lines are the lines it copies from their owners; listed
  // by the node chunk that writes them, so each is copied once it is final.
  // A node chunk fills whole lines, so no line has two writers.
  static_assert(3 * kNodesPerChunk % kLineValues == 0);
  const std::span<const int> node_begin = model_->part_node_begin();
  std::vector<std::vector<CutCopy>> per_chunk(node_chunks());
  for (int p = 0; p < model_->parts(); ++p) {
    const int chunks = (node_begin[p + 1] - node_begin[p] + kNodesPerChunk - 1) / kNodesPerChunk;
    node_chunk_part_.insert(node_chunk_part_.end(), chunks, p);
    for (int32_t line : model_->halo_lines(p)) per_chunk[line / 3 / kNodesPerChunk].push_back({p, line});
  }
  chunk_copies_begin_.push_back(0);
  for (const std::vector<CutCopy>& copies : per_chunk) {
    cut_copies_.insert(cut_copies_.end(), copies.begin(), copies.end());
    chunk_copies_begin_.push_back(static_cast<int>(cut_copies_.size()));
  }
}

template <typename T>
const typename TledSolver<T>::PartLevels& TledSolver<T>::OwnerOf(int layout_dof) const {
  return levels_[node_chunk_part_[layout_dof / 3 / kNodesPerChunk]];
}

template <typename T>
std::vector<T> TledSolver<T>::LevelInLayoutOrder(Level level) const {
  std::vector<T> values(3 * size_t(model_->num_nodes()));
  const std::span<const int> node_begin = model_->part_node_begin();
  for (int p = 0; p < model_->parts(); ++p) {
    const AlignedVector<T>& own = levels_[p].*level;
    std::copy(own.begin() + 3 * node_begin[p], own.begin() + 3 * node_begin[p + 1],
              values.begin() + 3 * node_begin[p]);
  }
  return values;
}

template <typename T>
std::span<const T> TledSolver<T>::LevelInMeshOrder(Level level, MeshOrderView& view) const {
  if (view.version == state_version_) return view.values;
  return InMeshOrder(LevelInLayoutOrder(level), view);
}

template <typename T>
Eigen::Matrix3Xd TledSolver<T>::DisplacementMatrix() const {
  Eigen::Matrix3Xd u(3, model_->num_nodes());
  const std::span<const T> mesh_order = displacement();
  for (int a = 0; a < model_->num_nodes(); ++a) {
    for (int i = 0; i < 3; ++i) u(i, a) = double(mesh_order[3 * a + i]);
  }
  return u;
}

template class TledSolver<float>;
template class TledSolver<double>;

}  // namespace dg::sim
