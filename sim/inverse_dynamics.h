#pragma once

#include <memory>
#include <span>
#include <vector>

#include "sim/aligned_vector.h"
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
  // node, metres) at times t - dt, t, t + dt.
  // @throws dg::Error if an element of U is inverted (J <= 0), naming it.
  void Recover(std::span<const T> u_prev, std::span<const T> u, std::span<const T> u_next,
               std::span<T> forces_n);

  const TledModel<T>& model() const { return *model_; }

 private:
  std::shared_ptr<const TledModel<T>> model_;
  std::vector<T> inertia_gain_;   // per node: M_a / (A dt^2)
  std::vector<T> gravity_force_;  // per node and axis: M_a g
  T increment_decay_ = 0;
  AlignedVector<T> element_forces_;
  std::vector<T> chunk_min_J_;
};

extern template class ForceRecovery<float>;
extern template class ForceRecovery<double>;

}  // namespace dg::sim
