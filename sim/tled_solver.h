#pragma once

#include <array>
#include <atomic>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sim/aligned_vector.h"
#include "sim/stability.h"
#include "sim/step_team.h"
#include "sim/tled_kernel.h"
#include "sim/tled_model.h"
#include "sim/time_step_policy.h"

namespace dg::sim {

struct SolverOptions {
  double dt_s = 2e-4;              // the paper's step
  double damping_per_s = 75.0;     // alpha of C = alpha M (paper section 2.3)
  Eigen::Vector3d gravity_m_s2 = Eigen::Vector3d::Zero();
  TimeStepPolicy time_step_policy = TimeStepPolicy::kRefuse;
  // Allowed fraction of the estimated dt_cr; 0: DefaultStabilitySafety() of
  // the material's Poisson's ratio (0.9 for compressible tissue, down to 0.65
  // for nearly incompressible).
  double stability_safety = 0;
  // Threads stepping the solver (its StepTeam's size); 0: DefaultTeamSize(),
  // the process's TBB parallelism. 1 where solvers already run side by side.
  int threads = 0;
  // Where the team's helper workers run (StepTeam): empty for the caller's TBB arena.
  HelperLauncher launch_helper;
  // Blow-up: kinetic energy growing more than energy_growth_limit times in each
  // of the last two windows of energy_window_steps steps. Physical motion from
  // rest grows as a power of t (at most (2W+1)^4/(W+1)^4 = 11x for the second
  // window even for a t^4 start); an unstable mode grows geometrically (at
  // 1.1 dt_cr, 5.9x per step). Checked every step, so a blow-up is named as
  // such before it inverts elements.
  int energy_window_steps = 5;
  double energy_growth_limit = 100.0;

  // Empty when valid; otherwise what is wrong and how to fix it.
  std::string Validate() const;
};

// Degrees of freedom (3 node + axis) held by boundary conditions.
struct BoundaryConditions {
  std::vector<int> fixed_dofs;       // held at zero displacement
  std::vector<int> prescribed_dofs;  // driven to targets given to Advance()
};

// Explicit TLED time integration of one mesh (paper eq. 3):
//   U+ = 2/(2 + alpha dt) [ dt^2/M (R - F(U)) + 2U + (alpha dt/2 - 1) U- ],
// computed in the algebraically identical increment form
//   U+ - U = A dt^2/M (R - F(U)) + (2 - alpha dt)/(2 + alpha dt) (U - U-),  A = 2/(2 + alpha dt),
// whose rest state is exactly R = F(U) whatever the coefficients round to: in
// float, the coefficients of eq. 3 sum to 1 only within 1e-7, which acts as a
// spurious spring of stiffness 1e-7 M/dt^2 and biased equilibrium reactions by 3e-4.
// Then fixed and prescribed degrees of freedom overwrite their components.
// Keeps the three time levels the formula needs and nothing else.
//
// Threading: Advance() runs its steps on a StepTeam (one given, or its own of
// options.threads, by default bounded by the caller's tbb::global_control;
// docs/solver.md): each step is a pass of element chunks, then node chunks
// (each worker's node chunks after the element chunks they gather from).
// With a part of the model for each worker, the workers run up to
// kFreeSteps steps between two barriers, each waiting only for the others'
// last step before its halo ("Free-running steps"); otherwise each step
// ends with the team's barrier. The serial section after a barrier does the
// steps' reductions and checks. Results do not depend on the thread count,
// nor does the state an inversion stops at; a blow-up found by the energy
// test alone is named at its step, with the state at the end of its pass.
// One solver must not be advanced from two threads at once. Advance()
// allocates nothing per step.
template <typename T>
class TledSolver {
 public:
  // Estimates the stability limit unless `stability` is given, and applies the
  // time-step policy. @throws dg::Error for invalid options, out-of-range
  // degrees of freedom, or (kRefuse) a time step above the safe limit.
  // `team` (optional) may be shared with other solvers stepped one at a time.
  TledSolver(std::shared_ptr<const TledModel<T>> model, BoundaryConditions conditions,
             const SolverOptions& options, const StabilityReport* stability = nullptr,
             std::shared_ptr<StepTeam> team = nullptr);

  // Advances `steps` time steps of dt_s; prescribed degrees of freedom move
  // linearly from their current values to `targets_m` (one per prescribed dof,
  // in the order given), reaching them at the last step.
  // @throws dg::Error on non-finite targets, an inverted element (J <= 0),
  // non-finite state or an energy blow-up, naming element or node, step and time.
  // After a throw the state is that of the last completed step.
  void Advance(int steps, std::span<const double> targets_m);

  // External nodal forces R (3 per node, N), applied from the next step on.
  // @throws dg::Error if a value is not finite.
  void SetExternalForces(std::span<const double> forces_n);

  // Resolved element loads (force resolution, paper eq. 5): weights in
  // ForceResolution's layout (one level, or two blended), applied in the
  // current geometry from the next step on, inside the element pass
  // (ComputeElementForcesLessLoads); a null first removes them. The caller
  // keeps the arrays alive and unchanged while stepping.
  void SetElementLoads(const ElementLoads<T>& loads) { element_loads_ = loads; }

  // Starts from displacement u (3 per node, m) and velocity v (m/s): U = u,
  // U- = u - v dt. @throws dg::Error on a size mismatch or non-finite value.
  void SetState(std::span<const double> u_m, std::span<const double> v_m_s);

  const TledModel<T>& model() const { return *model_; }
  const StabilityReport& stability() const { return stability_; }
  const SolverOptions& options() const { return options_; }
  int substeps_per_step() const { return substeps_; }
  // The fraction of dt_cr a step may take (SolverOptions::stability_safety resolved).
  double stability_safety() const { return safety_; }
  int threads() const { return team_->size(); }
  // The team that steps the solver, e.g. for where its workers' time goes (StepTeam::Timing).
  StepTeam& team() { return *team_; }
  double internal_dt_s() const { return options_.dt_s / substeps_; }
  long long steps_taken() const { return internal_steps_; }
  double time_s() const { return internal_steps_ * internal_dt_s(); }

  // Per-node state (3 per node) in the mesh's node order. The model keeps its
  // own node order inside (TledModel, "layout order"); these convert when
  // first asked after a change, so they are not to be called from two threads
  // at once, and a span lasts until the state changes.
  // Current displacement U, metres.
  std::span<const T> displacement() const { return LevelInMeshOrder(&PartLevels::u, displacement_view_); }
  Eigen::Matrix3Xd DisplacementMatrix() const;
  // A step checks the state it starts from, so the state after the last step
  // is checked by the next one. Before that state goes to an output: throws
  // the inversion error (as a step would) if an element of it is inverted or
  // degenerate, so that no inverted element and no non-finite stress is written.
  void CheckCurrentState() const;
  // Displacement U- of the step before, metres: with displacement(), the
  // whole state, e.g. to carry it into a solver with other boundary conditions.
  std::span<const T> previous_displacement() const { return LevelInMeshOrder(&PartLevels::u_prev, previous_view_); }
  // Internal force F(U) of the last step less the element loads, newtons.
  std::span<const T> internal_forces() const { return InMeshOrder(internal_force_, internal_force_view_); }
  // Force each constrained dof's support exerts on the body at the last step,
  // M a + alpha M v + F - R (zero on free dofs), newtons.
  std::span<const T> reaction_forces() const { return InMeshOrder(reaction_[LastStepEntry()], reaction_view_); }
  // Kinetic energy at the last completed step (central-difference velocity), joules.
  double kinetic_energy_j() const { return kinetic_energy_j_; }
  // Smallest element J seen at the last step.
  double min_jacobian() const { return min_J_; }

 private:
  // CoupledSimulation runs a step's parts beside the inverse simulation's.
  template <typename>
  friend class CoupledSimulation;

  // A copy of per-node state in the mesh's node order, made when asked after
  // the state changed.
  struct MeshOrderView {
    std::vector<T> values;
    long long version = -1;
  };
  template <typename Layout>
  std::span<const T> InMeshOrder(const Layout& layout, MeshOrderView& view) const;
  int LayoutDof(int dof) const { return 3 * model_->layout_node(dof / 3) + dof % 3; }

  // The displacements of each model part, in arrays of its own (docs/solver.md,
  // "Subdomains"): three time levels over all layout dofs, of which the part
  // writes its own nodes' and reads its own and its halo's. Each node chunk
  // copies the lines of its nodes that another part reads into that part's
  // next level, so the barrier ending the step (free-running: the part's
  // mark that its step is done) publishes them; no line of a part's arrays
  // is written by two cores.
  struct PartLevels {
    AlignedVector<T> u_prev, u, u_next;
  };
  using Level = AlignedVector<T> PartLevels::*;
  static constexpr int kLineValues = static_cast<int>(64 / sizeof(T));
  // A line of part `part`'s next level that a node chunk copies there from its own.
  struct CutCopy {
    int part;
    int offset;  // of the line's first value
  };
  // A time level, each node's value from the part that owns it.
  std::span<const T> LevelInMeshOrder(Level level, MeshOrderView& view) const;
  std::vector<T> LevelInLayoutOrder(Level level) const;
  const PartLevels& OwnerOf(int layout_dof) const;
  // Lists the lines each node chunk copies into other parts (cut_copies_).
  void ListCutCopies();

  // Advance()'s checks of the targets, and their begin and end values.
  void SetTargets(std::span<const double> targets_m);
  // One step of internal_dt_s() has three parts: ElementChunk(c) for every
  // c < element_chunks(), then NodeChunk(c, ...) for every c < node_chunks()
  // (each in any order, on any thread), then FinishStep() and CheckStep().
  // The chunks of step `ahead` past steps_taken() (free-running steps; 0
  // otherwise) read and write the time levels that step takes in the ring
  // of each part's three (RingLevel), and keep their reductions in row
  // `ahead` % kFreeSteps.
  int element_chunks() const { return model_->element_chunks(); }
  int node_chunks() const { return static_cast<int>(chunk_constrained_begin_.size()) - 1; }
  void ElementChunk(int chunk, int ahead = 0);
  // The forces (less the element loads) of element chunk `chunk` at
  // displacements `u` into the force array; the chunk's smallest J.
  T ChunkElementForces(int chunk, const T* u);
  // The update of the chunk's nodes; its prescribed dofs reach `fraction_end`
  // of the way from their begin to their end targets. `gathered`: the chunk's
  // nodal forces (3 per node, as GatherNodalForce sums them) if the caller
  // gathered them; null gathers here.
  void NodeChunk(int chunk, double fraction_end, const T* gathered = nullptr, int ahead = 0);
  // Worker `worker`'s requests for the lines of the cut its part exchanges
  // with the others (TledModel::halo_lines, cut_copies_), spread over the
  // first kCutRequestSlices element chunks of its own range: called before
  // each element chunk it runs, a slice of each list before each of those.
  void RequestCutLines(int worker, int chunk) const;
  static constexpr int kCutRequestSlices = 8;
  void FinishStep();
  // The step's checks on its reductions in row `row`.
  void CheckStep(int row = 0);
  // The kinetic energy of the step whose reductions are in row `row`.
  double KineticEnergy(int row) const;
  // Lists each part's first element chunk that reads another part's lines (wait_chunk_).
  void ListWaitChunks();

  // Free-running steps (docs/solver.md, "Free-running steps"): with a part
  // for each worker, a pass of the team runs up to kFreeSteps steps, each
  // worker its own part's, and a part waits before its halo for every other
  // part's last step. The rest of the team's barrier goes to the pass's end.
  static constexpr int kFreeSteps = 32;
  bool RunsFree() const;
  void AdvanceFree(int total);
  // Part `part`'s step `ahead` past steps_taken(), its prescribed dofs at
  // `fraction_end`: false, having written nothing the state keeps, when a
  // part stopped at an earlier step.
  bool FreeStep(int part, int ahead, double fraction_end);
  // The serial end of a pass of `steps` free-running steps: the state moves
  // to the last step completed, and each step's reductions and checks run
  // as CheckStep's would, in order (so a stop throws there).
  void FinishFreeSteps(int steps);
  // Internal forces of the step that starts from the current U-, as that
  // step computed them: after a stop, for nodes whose part went on.
  void RecomputeInternalForces();
  // The time level `which` (0: U-, 1: U, 2: U+) of part `part` at step
  // `ahead` past steps_taken(): a ring of its three arrays, pinned at the
  // Advance's start (ring_).
  T* RingLevel(int part, int ahead, int which) const { return ring_[part][(ahead + which) % 3]; }
  // Points the ring at the parts' arrays as named now.
  void PinRing();
  // The entry of the two-step ring of reactions (reaction_) of step `ahead`
  // past steps_taken(), and of the last completed step.
  int StepEntry(int ahead) const { return static_cast<int>((internal_steps_ + ahead) % 2); }
  int LastStepEntry() const { return static_cast<int>((internal_steps_ + 1) % 2); }
  bool EnergyBlowingUp() const;
  // The error for the most inverted element of state u at `step`.
  [[noreturn]] void ThrowInversion(const T* u, long long step) const;

  std::shared_ptr<const TledModel<T>> model_;
  BoundaryConditions conditions_;
  SolverOptions options_;
  StabilityReport stability_;
  double safety_ = 0;  // the allowed fraction of dt_cr: the option's, or the material's default
  std::shared_ptr<StepTeam> team_;
  ChunkHomes homes_;  // each worker's element and node chunks (PartitionChunks)
  int substeps_ = 1;

  // Per node: A dt^2 / M_a with A = 2 / (2 + alpha dt); per component A dt^2 g.
  std::vector<T> force_gain_;
  T gravity_term_[3] = {0, 0, 0};
  T increment_decay_ = 0;  // (2 - alpha dt) / (2 + alpha dt)
  // Per layout dof: -1 free, -2 fixed, else the index into the prescribed targets.
  std::vector<int> dof_kind_;
  std::vector<int> prescribed_layout_dofs_;  // the layout dof of each prescribed target
  std::vector<int> constrained_dofs_;        // layout dofs, sorted
  std::vector<int> chunk_constrained_begin_;  // node chunk c's are [begin[c], begin[c + 1]) of constrained_dofs_
  std::vector<T> free_mass_;           // per dof: nodal mass, 0 where constrained
  std::vector<double> target_begin_, target_end_;

  std::vector<PartLevels> levels_;           // per model part
  std::vector<std::array<T*, 3>> ring_;      // per part: its U-, U, U+ at the ring's step 0
  // Free-running: the last step each part completed, and the step a part
  // stopped at (an inverted element), each on a line of its own; held apart
  // so that the solver stays movable.
  struct FreeProgress {
    struct alignas(64) Step {
      std::atomic<long long> value{-1};
    };
    explicit FreeProgress(int parts) : done(parts) {}
    std::vector<Step> done;  // per part
    Step stopped_at;
  };
  std::unique_ptr<FreeProgress> progress_;
  std::vector<int> wait_chunk_;  // per part: the first element chunk that reads the other parts' lines
  std::vector<int> element_chunk_part_, node_chunk_part_;
  std::vector<CutCopy> cut_copies_;
  std::vector<int> chunk_copies_begin_;  // node chunk c's are [begin[c], begin[c + 1]) of cut_copies_
  AlignedVector<T> element_forces_;
  ElementLoads<T> element_loads_;  // none while its first is null
  std::vector<T> external_force_;
  std::vector<T> internal_force_;
  // By StepEntry(): a part one step ahead of a stop (free-running) writes
  // the other. (Internal forces, written at every node, are recomputed
  // after a stop instead: a second array would cost every step its traffic.)
  std::array<std::vector<T>, 2> reaction_;
  // kFreeSteps rows, one a step: per element chunk its smallest J, per node
  // chunk twice its kinetic energy times (2 dt)^2.
  std::vector<T> chunk_min_J_;
  std::vector<double> chunk_kinetic_;

  long long internal_steps_ = 0;
  long long state_version_ = 0;  // changes with every step and SetState()
  mutable MeshOrderView displacement_view_, previous_view_, internal_force_view_, reaction_view_;
  double kinetic_energy_j_ = 0;
  double min_J_ = 1;
  // Kinetic energy of the last 2W + 1 steps, a ring indexed by step.
  std::vector<double> energy_history_;
};

template <typename T>
template <typename Layout>
std::span<const T> TledSolver<T>::InMeshOrder(const Layout& layout, MeshOrderView& view) const {
  if (view.version != state_version_) {
    view.values.resize(layout.size());
    model_->ToMeshOrder(std::span<const T>(layout.data(), layout.size()), std::span<T>(view.values));
    view.version = state_version_;
  }
  return view.values;
}

extern template class TledSolver<float>;
extern template class TledSolver<double>;

}  // namespace dg::sim
