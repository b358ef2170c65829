#pragma once

#include <span>
#include <vector>

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

// The same pass less each element's resolved loads (force resolution, paper
// eq. 5; see force_resolution.h for the weights' form): corner c of an element
// receives D q_c, D = D0 + (u_j - u_0) its edges in the geometry X + u and q_c
// its weights in load_weights ([block][corner][xyz][lane]); `forces` gets
// f_c - D q_c, so a node's gathered sum is F(U) less the applied load. Folding
// the load into this pass reuses the edge displacements the forces need.
template <typename T>
T ComputeElementForcesLessLoads(const TledModel<T>& model, const T* u, const T* load_weights, T* forces,
                                int block_begin, int block_end);

// The inverse simulation's element pass (paper eqs. 4 and 5, one level apart):
// besides the forces at u, it resolves the previous level's nodal forces with
// the previous level's edge inverses, q_c = D^-1 (r_c / n_c), into `weights`,
// then overwrites `edge_inverse` with the rows of D^-1 of the geometry X + u
// (zero for padding) and sets min_volume_ratio to the blocks' smallest
// det(D) / det(D0), which is J (1 for padding). D^-1 = D0^-1 F^-1 comes from the
// cofactors and J the forces need: no edge matrix is formed.
template <typename T>
struct ResolveBuffers {
  T* edge_inverse = nullptr;            // [block][row][column][lane], in and out
  const T* scaled_forces_n = nullptr;   // per node and axis: r / n_a of the previous level
  T* weights = nullptr;                 // [block][corner][xyz][lane], out
  T min_volume_ratio = 1;               // out
};
template <typename T>
T ComputeElementForcesAndResolve(const TledModel<T>& model, const T* u, ResolveBuffers<T>* resolve, T* forces,
                                 int block_begin, int block_end);

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

// Nodes per unit of parallel work in the node passes. Partial results (kinetic
// energy) are kept per chunk, so they combine in the same order whatever the thread count.
constexpr int kNodesPerChunk = 128;
template <typename T>
int NodeChunks(const TledModel<T>& model) {
  return (model.num_nodes() + kNodesPerChunk - 1) / kNodesPerChunk;
}

// Home ranges of element and node chunks for a team of `parts` workers
// (StepTeam::ForEachChunk), each parts + 1 bounds, that keep a worker's
// elements and nodes in the same region of the body: elements are sorted by
// their first layout node, so the node chunks are split where the elements'
// count is split evenly, and the element chunks where their first node
// crosses into the next worker's nodes. A node then gathers mostly forces its
// own worker wrote in the same step, from its own core's cache.
struct ChunkHomes {
  std::vector<int> elements, nodes;
};
template <typename T>
ChunkHomes PartitionChunks(const TledModel<T>& model, int parts);

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

// The nodal forces of the chunk of nodes [begin, end), 3 per node: `gathered`
// when the caller gathered them already (GatherNodalForces for two passes at
// once), else gathered here into `own` (room for 3 (end - begin)).
template <typename T>
inline const T* ChunkNodalForces(const TledModel<T>& model, const T* forces, int begin, int end, const T* gathered,
                                 T* own) {
  if (gathered) return gathered;
  for (int a = begin; a < end; ++a) GatherNodalForce(model, forces, a, &own[3 * (a - begin)]);
  return own;
}

// GatherNodalForce of two force arrays in one walk over node a's incidences,
// each summed in the same order as GatherNodalForce (bitwise the same sums):
// one loop's control and offsets serve both, and the two chains overlap.
template <typename T>
inline void GatherNodalForces(const TledModel<T>& model, const T* forces_a, const T* forces_b, int a, T* f_a,
                              T* f_b) {
  constexpr int W = TledModel<T>::kLanes;
  const int32_t* offsets = model.gather_offsets().data();
  T ax = 0, ay = 0, az = 0, bx = 0, by = 0, bz = 0;
  for (int k = model.gather_begin()[a]; k < model.gather_begin()[a + 1]; ++k) {
    const T* corner_a = forces_a + offsets[k];
    const T* corner_b = forces_b + offsets[k];
    ax += corner_a[0];
    ay += corner_a[W];
    az += corner_a[2 * W];
    bx += corner_b[0];
    by += corner_b[W];
    bz += corner_b[2 * W];
  }
  f_a[0] = ax;
  f_a[1] = ay;
  f_a[2] = az;
  f_b[0] = bx;
  f_b[1] = by;
  f_b[2] = bz;
}

// x^(-1/3) for x > 0, branch-free so the element loop vectorises: a bit-level
// first guess (exponent divided by three) refined by Newton's iteration
// y <- y (4 - x y^3) / 3, whose error squares each time; agrees with
// std::pow(x, -1/3) to round-off over [1e-12, 1e12].
template <typename T>
T InverseCubeRoot(T x);

}  // namespace dg::sim
