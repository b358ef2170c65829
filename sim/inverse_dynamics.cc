#include "sim/inverse_dynamics.h"

#include <algorithm>
#include <cstdio>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "sim/error.h"
#include "sim/force_resolution.h"
#include "sim/tled_kernel.h"

namespace dg::sim {
namespace {

constexpr int kNodesPerChunk = 256;

}  // namespace

template <typename T>
ForceRecovery<T>::ForceRecovery(std::shared_ptr<const TledModel<T>> model, const SolverOptions& options)
    : model_(std::move(model)) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid inverse simulation options: " + problem, "solver options", "correct the option");
  }
  const double dt = options.dt_s, alpha = options.damping_per_s;
  const double A = 2.0 / (2.0 + alpha * dt);
  increment_decay_ = static_cast<T>((2.0 - alpha * dt) / (2.0 + alpha * dt));
  const std::vector<double>& mass = model_->lumped_mass_kg();
  inertia_gain_.resize(mass.size());
  gravity_force_.resize(3 * mass.size());
  for (size_t a = 0; a < mass.size(); ++a) {
    inertia_gain_[a] = static_cast<T>(mass[a] / (A * dt * dt));
    for (int i = 0; i < 3; ++i) gravity_force_[3 * a + i] = static_cast<T>(mass[a] * options.gravity_m_s2[i]);
  }
  element_forces_.assign(model_->force_array_size(), T(0));
  chunk_min_J_.assign(ElementChunks(*model_), T(1));
}

template <typename T>
void ForceRecovery<T>::Recover(std::span<const T> u_prev, std::span<const T> u, std::span<const T> u_next,
                               std::span<T> forces_n) {
  const TledModel<T>& model = *model_;
  const size_t n_dofs = 3 * size_t(model.num_nodes());
  DG_CHECK(u_prev.size() == n_dofs && u.size() == n_dofs && u_next.size() == n_dofs && forces_n.size() == n_dofs);
  ComputeElementForcesParallel(model, u.data(), element_forces_.data(), std::span<T>(chunk_min_J_));
  if (!(*std::min_element(chunk_min_J_.begin(), chunk_min_J_.end()) > 0)) {
    const WorstElement worst = FindWorstElement(model.mesh(), u.data());
    char where[96];
    std::snprintf(where, sizeof where, "element %d (J = %.3g) of the motion model's geometry", worst.element,
                  worst.volume_ratio);
    throw Error("inverted element in the preoperative motion", where,
                "check the motion model (scan registration) there, or smooth it");
  }
  const int chunks = (model.num_nodes() + kNodesPerChunk - 1) / kNodesPerChunk;
  tbb::parallel_for(tbb::blocked_range<int>(0, chunks), [&](const tbb::blocked_range<int>& range) {
    for (int c = range.begin(); c != range.end(); ++c) {
      const int end = std::min((c + 1) * kNodesPerChunk, model.num_nodes());
      for (int a = c * kNodesPerChunk; a < end; ++a) {
        T f[3];
        GatherNodalForce(model, element_forces_.data(), a, f);
        for (int i = 0; i < 3; ++i) {
          const size_t dof = 3 * size_t(a) + i;
          const T increment = (u_next[dof] - u[dof]) - increment_decay_ * (u[dof] - u_prev[dof]);
          forces_n[dof] = f[i] + inertia_gain_[a] * increment - gravity_force_[dof];
        }
      }
    }
  });
}

template class ForceRecovery<float>;
template class ForceRecovery<double>;

}  // namespace dg::sim
