#pragma once

#include <memory>
#include <span>
#include <vector>

#include "sim/aligned_vector.h"
#include "sim/motion_model.h"
#include "sim/phase_clock.h"
#include "sim/tled_model.h"
#include "sim/tled_solver.h"

namespace dg::sim {

// Inverse simulation (paper eq. 4): the external nodal forces under which the
// forward update of TledSolver moves the mesh through three given time levels,
//   R = M/dt^2 [ (1 + alpha dt/2) U+ - 2U - (alpha dt/2 - 1) U- ] + F(U) - M g,
// written, like the solver, in increment form
//   R = F(U) + M / (A dt^2) [ (U+ - U) - (2 - alpha dt)/(2 + alpha dt) (U - U-) ] - M g,
//   A = 2 / (2 + alpha dt),
// so that applying R in the forward step reproduces U+ to round-off (no
// constraint acting). F(U) is the TLED kernel's internal force at U.
//
// Threading: Recover() runs its element and node loops under tbb::parallel_for
// in fixed chunks: results do not depend on the thread count. One instance
// must not be used from two threads at once. Recover() allocates nothing.
template <typename T>
class ForceRecovery {
 public:
  // Uses options.dt_s, damping_per_s and gravity_m_s2.
  // @throws dg::Error for invalid options.
  ForceRecovery(std::shared_ptr<const TledModel<T>> model, const SolverOptions& options);

  // Forces (3 per node, newtons) for displacements u_prev, u, u_next (3 per
  // node, metres) at times t - dt, t, t + dt, all in the mesh's node order.
  // @throws dg::Error if an element of U is inverted (J <= 0), naming it.
  void Recover(std::span<const T> u_prev, std::span<const T> u, std::span<const T> u_next,
               std::span<T> forces_n);

  const TledModel<T>& model() const { return *model_; }

 private:
  // Recover() in layout order.
  void Recover(const T* u_prev, const T* u, const T* u_next, T* forces_n);

  std::shared_ptr<const TledModel<T>> model_;
  std::vector<T> inertia_gain_;   // per node: M_a / (A dt^2)
  std::vector<T> gravity_force_;  // per node and axis: M_a g
  T increment_decay_ = 0;
  AlignedVector<T> element_forces_;
  std::vector<T> chunk_min_J_;
  std::vector<T> layout_levels_[3], layout_forces_;  // Recover()'s arguments in layout order
};

extern template class ForceRecovery<float>;
extern template class ForceRecovery<double>;

// The inverse side of the coupled simulation (paper section 2.6): level by
// level, level n at step s = n k (k = interval_steps; t = s dt, the motion
// model Um at phase_clock()'s phase: phase_at_start + t / period unless
// steered), the weights (eq. 5,
// ForceResolution's layout) of the forces that ForceRecovery would recover
// from Um at steps s - 1, s, s + 1 (eq. 4, the forward step's own stencil),
// resolved in the geometry X + Um_n. With k = 1 the levels are the forward
// steps; with k > 1 the caller blends two levels in between (docs/solver.md,
// "Recovered forces at a coarser rate"). The same arithmetic as ForceRecovery
// followed by ForceResolution::Resolve, arranged for speed:
//  - an element pass at Um_{n+2} computes the internal forces there and the
//    edge inverses D^-1 (from the cofactors of F the forces need), and with
//    the inverses of Um_{n+1} (stored by the previous pass) resolves the
//    forces of n + 1 into the weights of n + 1: one pass over the elements
//    instead of three (recovery, resolution, application);
//  - a node pass gathers the forces of n + 2, evaluates Um_{n+3} for its own
//    nodes only (the slot Um_n leaves), and stores r / n_a, the share of each
//    element, so the resolution multiplies by no count. With k > 1 it also
//    evaluates its nodes' Um one step either side of level n + 2.
// Three motion levels, one set of edge inverses and three weight sets (the
// two newest levels' and the one being written) are kept, all in the model's
// layout order (the motion model is reordered once).
//
// Threading: a level's parts are ElementChunk(c) for every c < element_chunks(),
// then NodeChunk(c) for every c < node_chunks() (each in any order and on any
// thread: every chunk writes only its own part), then Finish(); Advance() runs
// them under tbb::parallel_for. A caller may run them beside other work, as the
// coupled simulation runs the forward step's, and read the weights of level()
// and level() - 1 meanwhile. Results do not depend on the order or the thread
// count. Nothing allocates after construction.
template <typename T>
class InverseSimulation {
 public:
  // Uses options.dt_s, damping_per_s and gravity_m_s2.
  // @pre motion->dofs() == 3 * model->num_nodes(), interval_steps >= 1
  // @throws dg::Error for invalid options, or as Finish() does for levels 0 to 3.
  InverseSimulation(std::shared_ptr<const TledModel<T>> model, std::shared_ptr<const CyclicMotionModel> motion,
                    const SolverOptions& options, double phase_at_start, int interval_steps = 1);

  // The newest level whose weights are complete (1 after construction).
  long long level() const { return pending_level_ - 2; }
  int interval_steps() const { return interval_steps_; }
  // The weights of `level`. @pre level() - 2 <= level <= level(); those of
  // level() - 2 are overwritten by the next level's element pass.
  std::span<const T> weights(long long level) const;

  // Moves to the next level (all parts under tbb::parallel_for).
  // @throws dg::Error as Finish() does.
  void Advance();

  // The motion model's phase by step; steering it changes only steps after newest_motion_step().
  PhaseClock& phase_clock() { return clock_; }
  const PhaseClock& phase_clock() const { return clock_; }
  // The last step whose motion a level has evaluated.
  long long newest_motion_step() const { return pending_level_ * interval_steps_ + 1; }

  int element_chunks() const { return static_cast<int>(chunk_min_J_.size()); }
  int node_chunks() const { return static_cast<int>(chunk_node_count_); }
  void ElementChunk(int chunk);
  // `gathered`: the chunk's nodal forces (3 per node, as GatherNodalForce
  // sums them) if the caller gathered them; null gathers here.
  void NodeChunk(int chunk, const T* gathered = nullptr);
  // @throws dg::Error if an element of the motion model's geometry at level() + 2
  // is inverted (J <= 0) or degenerate (volume ratio below
  // ForceResolution::kMinVolumeRatio), naming it; the simulation cannot go on after it.
  void Finish();

 private:
  // CoupledSimulation gathers this side's and the solver's nodal forces together.
  template <typename>
  friend class CoupledSimulation;

  int Slot(long long level) const { return static_cast<int>(((level % 3) + 3) % 3); }
  int Parity(long long level) const { return static_cast<int>(((level % 2) + 2) % 2); }
  double PhaseOfStep(long long step) const { return clock_.PhaseAt(step); }

  std::shared_ptr<const TledModel<T>> model_;
  CyclicMotionModel motion_;  // in the model's layout order
  double dt_s_ = 0;
  PhaseClock clock_;
  int interval_steps_ = 1;
  std::vector<T> inertia_gain_;   // per node: M_a / (A dt^2)
  std::vector<T> gravity_force_;  // per node and axis: M_a g
  std::vector<T> inverse_count_;  // per node: 1 / (number of its elements)
  T increment_decay_ = 0;
  // The level whose forces the next element pass computes; its weights follow two levels on.
  long long pending_level_ = 0;
  std::vector<T> motion_levels_[3];  // ring indexed by level % 3
  AlignedVector<T> element_forces_;  // at the pending level
  AlignedVector<T> edge_inverse_;    // rows of D^-1 at the last element pass's level
  // r / n_a (3 per node) of a level, indexed by level % 2: a node chunk writes
  // the pending level's while element chunks of other parts, in the same pass,
  // still resolve the level before (StepTeam::ForEachChunkThen).
  std::vector<T> scaled_forces_[2];
  AlignedVector<T> weights_[3];      // ring indexed by level % 3
  std::vector<T> chunk_min_J_, chunk_min_ratio_;
  int chunk_node_count_ = 0;
};

extern template class InverseSimulation<float>;
extern template class InverseSimulation<double>;

}  // namespace dg::sim
