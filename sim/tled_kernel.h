#pragma once

#include <span>

#include "sim/tled_model.h"

namespace dg::sim {

// Internal nodal forces of the neo-Hookean elements in blocks [block_begin,
// block_end) at displacement u (3 per node, xyz interleaved, metres):
//   F = I + sum_a u_a (x) dN_a/dX,  C = F^T F,  J = det F,
//   S = mu J^(-2/3) (I - tr(C)/3 C^-1) + kappa J (J - 1) C^-1,
//   f_a = V0 F S dN_a/dX                        (the "t0F" of paper eq. 3),
// evaluated as F S = mu J^(-2/3) F + (kappa (J - 1) - mu J^(-5/3) tr(C)/3) cof(F),
// written to the element-major array `forces` ([block][corner][xyz][lane]).
// Returns the smallest J in those blocks (padding lanes have J = 1).
// Touches only its own blocks' part of `forces`: blocks may run in parallel.
// Allocates nothing.
template <typename T>
T ComputeElementForces(const TledModel<T>& model, const T* u, T* forces, int block_begin,
                       int block_end);

// Blocks per unit of parallel work in the element pass. Partial results (the
// smallest J) are kept per chunk, so they combine in the same order whatever
// the thread count.
constexpr int kBlocksPerChunk = 8;
template <typename T>
int ElementChunks(const TledModel<T>& model) {
  return (model.num_blocks() + kBlocksPerChunk - 1) / kBlocksPerChunk;
}

// ComputeElementForces over all blocks under tbb::parallel_for, chunk c
// writing its smallest J to chunk_min_J[c]. @pre chunk_min_J.size() == ElementChunks(model)
template <typename T>
void ComputeElementForcesParallel(const TledModel<T>& model, const T* u, T* forces, std::span<T> chunk_min_J);

// Sum of the element forces at node a, in the model's fixed order (deterministic).
template <typename T>
inline void GatherNodalForce(const TledModel<T>& model, const T* forces, int a, T* f) {
  constexpr int W = TledModel<T>::kLanes;
  const int32_t* offsets = model.gather_offsets().data();
  T fx = 0, fy = 0, fz = 0;
  for (int k = model.gather_begin()[a]; k < model.gather_begin()[a + 1]; ++k) {
    const T* corner = forces + offsets[k];
    fx += corner[0];
    fy += corner[W];
    fz += corner[2 * W];
  }
  f[0] = fx;
  f[1] = fy;
  f[2] = fz;
}

// x^(-1/3) for x > 0, branch-free so the element loop vectorises: a bit-level
// first guess (exponent divided by three) refined by Newton's iteration
// y <- y (4 - x y^3) / 3, whose error squares each time; agrees with
// std::pow(x, -1/3) to round-off over [1e-12, 1e12].
template <typename T>
T InverseCubeRoot(T x);

}  // namespace dg::sim
