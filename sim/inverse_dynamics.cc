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


// Runs body(c) for c in [0, count) under tbb::parallel_for.
template <typename Body>
void ForEachChunk(int count, Body body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, count), [&](const tbb::blocked_range<int>& range) {
    for (int c = range.begin(); c != range.end(); ++c) body(c);
  });
}

template <typename T>
[[noreturn]] void ThrowInvertedMotion(const TetMesh& mesh, const T* u) {
  const WorstElement worst = FindWorstElement(mesh, u);
  char at[64];
  std::snprintf(at, sizeof at, " (J = %.3g) of the motion model's geometry", worst.volume_ratio);
  throw Error("inverted element in the preoperative motion", ElementName(mesh, worst.element) + at,
              "check the motion model (scan registration) there, or smooth it");
}

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
  chunk_min_J_.assign(model_->element_chunks(), T(1));
  for (std::vector<T>& level : layout_levels_) level.resize(3 * mass.size());
  layout_forces_.resize(3 * mass.size());
}

template <typename T>
void ForceRecovery<T>::Recover(std::span<const T> u_prev, std::span<const T> u, std::span<const T> u_next,
                               std::span<T> forces_n) {
  const TledModel<T>& model = *model_;
  const size_t n_dofs = 3 * size_t(model.num_nodes());
  DG_CHECK(u_prev.size() == n_dofs && u.size() == n_dofs && u_next.size() == n_dofs && forces_n.size() == n_dofs);
  model.ToLayout(u_prev, std::span<T>(layout_levels_[0]));
  model.ToLayout(u, std::span<T>(layout_levels_[1]));
  model.ToLayout(u_next, std::span<T>(layout_levels_[2]));
  Recover(layout_levels_[0].data(), layout_levels_[1].data(), layout_levels_[2].data(), layout_forces_.data());
  model.ToMeshOrder(std::span<const T>(layout_forces_), forces_n);
}

template <typename T>
void ForceRecovery<T>::Recover(const T* __restrict u_prev, const T* __restrict u, const T* __restrict u_next,
                               T* __restrict forces_n) {
  const TledModel<T>& model = *model_;
  ComputeElementForcesParallel(model, u, element_forces_.data(), std::span<T>(chunk_min_J_));
  if (!(*std::min_element(chunk_min_J_.begin(), chunk_min_J_.end()) > 0)) ThrowInvertedMotion(model.layout_mesh(), u);
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

template <typename T>
InverseSimulation<T>::InverseSimulation(std::shared_ptr<const TledModel<T>> model,
                                        std::shared_ptr<const CyclicMotionModel> motion, const SolverOptions& options,
                                        double phase_at_start, int interval_steps)
    : model_(std::move(model)),
      motion_(motion->Reordered(model_->mesh_nodes_in_layout_order())),
      dt_s_(options.dt_s),
      clock_(phase_at_start, options.dt_s / motion->period_s()),
      interval_steps_(interval_steps) {
  DG_CHECK(interval_steps_ >= 1);
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid inverse simulation options: " + problem, "solver options", "correct the option");
  }
  const int N = model_->num_nodes();
  DG_CHECK(motion_.dofs() == 3 * N);
  const double dt = options.dt_s, alpha = options.damping_per_s;
  const double A = 2.0 / (2.0 + alpha * dt);
  increment_decay_ = static_cast<T>((2.0 - alpha * dt) / (2.0 + alpha * dt));
  const std::vector<double>& mass = model_->lumped_mass_kg();
  inertia_gain_.resize(N);
  gravity_force_.resize(3 * size_t(N));
  inverse_count_.resize(N);
  for (int a = 0; a < N; ++a) {
    inertia_gain_[a] = static_cast<T>(mass[a] / (A * dt * dt));
    for (int i = 0; i < 3; ++i) gravity_force_[3 * a + i] = static_cast<T>(mass[a] * options.gravity_m_s2[i]);
    inverse_count_[a] = T(1) / static_cast<T>(model_->gather_begin()[a + 1] - model_->gather_begin()[a]);
  }
  for (auto& level : motion_levels_) level.assign(3 * size_t(N), T(0));
  element_forces_.assign(model_->force_array_size(), T(0));
  edge_inverse_.assign(size_t(model_->num_blocks()) * 9 * TledModel<T>::kLanes, T(0));
  for (std::vector<T>& level : scaled_forces_) level.assign(3 * size_t(N), T(0));
  for (AlignedVector<T>& level : weights_) level.assign(model_->force_array_size(), T(0));
  chunk_min_J_.assign(model_->element_chunks(), T(1));
  chunk_min_ratio_.assign(model_->element_chunks(), T(1));
  chunk_node_count_ = NodeChunks(*model_);
  // Level 0's forces need Um_-1 and Um_0 (the node pass adds Um_1); three
  // passes then bring the weights of levels 0 and 1 (the first pass resolves zeros).
  pending_level_ = 0;
  motion_.Evaluate<T>(PhaseOfStep(-1), std::span<T>(motion_levels_[Slot(-1)]));
  motion_.Evaluate<T>(PhaseOfStep(0), std::span<T>(motion_levels_[Slot(0)]));
  for (int pass = 0; pass < 3; ++pass) Advance();
}

template <typename T>
std::span<const T> InverseSimulation<T>::weights(long long level) const {
  DG_CHECK(level <= this->level() && level >= this->level() - 2);
  const AlignedVector<T>& w = weights_[Slot(level)];
  return {w.data(), w.size()};
}

template <typename T>
void InverseSimulation<T>::Advance() {
  ForEachChunk(element_chunks(), [&](int c) { ElementChunk(c); });
  ForEachChunk(node_chunks(), [&](int c) { NodeChunk(c); });
  Finish();
}

template <typename T>
void InverseSimulation<T>::ElementChunk(int chunk) {
  const int begin = model_->chunk_block_begin(chunk), end = model_->chunk_block_begin(chunk + 1);
  // The pass resolves the level before the pending one.
  ResolveBuffers<T> resolve{edge_inverse_.data(), scaled_forces_[Parity(pending_level_ - 1)].data(),
                           weights_[Slot(pending_level_ - 1)].data()};
  chunk_min_J_[chunk] = ComputeElementForcesAndResolve(*model_, motion_levels_[Slot(pending_level_)].data(), &resolve,
                                                       element_forces_.data(), begin, end);
  chunk_min_ratio_[chunk] = resolve.min_volume_ratio;
}

template <typename T>
void InverseSimulation<T>::NodeChunk(int chunk, const T* gathered) {
  // R = F(U) + M / (A dt^2) [ (U+ - U) - (2 - alpha dt)/(2 + alpha dt) (U - U-) ] - M g (eq. 4, see ForceRecovery).
  const TledModel<T>& model = *model_;
  const int begin = chunk * kNodesPerChunk;
  const int end = std::min(begin + kNodesPerChunk, model.num_nodes());
  T own[3 * kNodesPerChunk];
  gathered = ChunkNodalForces(model, element_forces_.data(), begin, end, gathered, own);
  const size_t first = 3 * size_t(begin), count = 3 * size_t(end - begin);
  const long long step = pending_level_ * interval_steps_;
  T* scaled_forces = scaled_forces_[Parity(pending_level_)].data();
  T* next_level = motion_levels_[Slot(pending_level_ + 1)].data() + first;
  motion_.Evaluate<T>(PhaseOfStep(step + interval_steps_), static_cast<int>(first), std::span<T>(next_level, count));
  // The stencil one step either side: the neighbouring levels when they are one step apart.
  const T* __restrict u = motion_levels_[Slot(pending_level_)].data() + first;
  const T* __restrict u_prev = motion_levels_[Slot(pending_level_ - 1)].data() + first;
  const T* __restrict u_next = next_level;
  T step_before[3 * kNodesPerChunk], step_after[3 * kNodesPerChunk];
  if (interval_steps_ > 1) {
    motion_.Evaluate<T>(PhaseOfStep(step - 1), static_cast<int>(first), std::span<T>(step_before, count));
    motion_.Evaluate<T>(PhaseOfStep(step + 1), static_cast<int>(first), std::span<T>(step_after, count));
    u_prev = step_before;
    u_next = step_after;
  }
  for (int a = begin; a < end; ++a) {
    const T* f = &gathered[3 * (a - begin)];
    for (int i = 0; i < 3; ++i) {
      const size_t local = 3 * size_t(a - begin) + i, dof = first + local;
      const T increment = (u_next[local] - u[local]) - increment_decay_ * (u[local] - u_prev[local]);
      scaled_forces[dof] = (f[i] + inertia_gain_[a] * increment - gravity_force_[dof]) * inverse_count_[a];
    }
  }
}

template <typename T>
void InverseSimulation<T>::Finish() {
  const T* u = motion_levels_[Slot(pending_level_)].data();
  if (!(*std::min_element(chunk_min_J_.begin(), chunk_min_J_.end()) > 0)) ThrowInvertedMotion(model_->layout_mesh(), u);
  constexpr double kMinRatio = ForceResolution<T>::kMinVolumeRatio;
  if (!(*std::min_element(chunk_min_ratio_.begin(), chunk_min_ratio_.end()) >= T(kMinRatio))) {
    ThrowDegenerateEdges(model_->layout_mesh(), FindWorstElement(model_->layout_mesh(), u), kMinRatio,
                         "the motion model's geometry while running");
  }
  ++pending_level_;
}

template class InverseSimulation<float>;
template class InverseSimulation<double>;

}  // namespace dg::sim
