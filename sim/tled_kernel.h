#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "sim/step_team.h"
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
// its weights ([block][corner][xyz][lane]); `forces` gets f_c - D q_c, so a
// node's gathered sum is F(U) less the applied load. Folding the load into
// this pass reuses the edge displacements the forces need.
// The weights are q = first + blend (second - first): a time between two
// levels of recovered loads (docs/solver.md, "Recovered forces at a coarser
// rate"); with blend 0 (or no second) they are `first`, bitwise.
template <typename T>
struct ElementLoads {
  const T* first = nullptr;
  const T* second = nullptr;
  T blend = 0;
};
template <typename T>
T ComputeElementForcesLessLoads(const TledModel<T>& model, const T* u, const ElementLoads<T>& loads, T* forces,
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

// ComputeElementForces over all blocks under tbb::parallel_for, chunk c
// writing its smallest J to chunk_min_J[c]. @pre chunk_min_J.size() == model.element_chunks()
template <typename T>
void ComputeElementForcesParallel(const TledModel<T>& model, const T* u, T* forces, std::span<T> chunk_min_J);

template <typename T>
int NodeChunks(const TledModel<T>& model) {
  return (model.num_nodes() + kNodesPerChunk - 1) / kNodesPerChunk;
}

// Home ranges of element and node chunks for a team of `parts` workers
// (StepTeam::ForEachChunkThen), each parts + 1 bounds, that keep a worker's
// elements and nodes in the same region of the body. For a model of that
// many parts they are its parts: a node gathers only forces its own worker
// wrote, and each node chunk runs as soon as the part's element chunks it
// gathers from are done. Otherwise, since elements are sorted by their first
// layout node, the node chunks are split where the elements' count is split
// evenly, and the element chunks where their first node crosses into the
// next worker's nodes: a node then gathers mostly forces from its own core's
// cache, once every element chunk is done.
struct ChunkHomes {
  std::vector<int> elements, nodes;
  StepTeam::ThenOrder node_order;
};
template <typename T>
ChunkHomes PartitionChunks(const TledModel<T>& model, int parts);

// The sums of node a's element-corner forces in each of N element-major force
// arrays (forces[i] -> sums[i], 3 each), in one walk over its incidences.
// Two partial sums per component, over the incidences in even and odd places
// of the node's list, then added: the order is fixed by the model (results do
// not depend on threads or on N), and two chains halve the wait on the adder's
// latency, which is what bounds a single chain (a node has some 19 incidences).
template <typename T, size_t N>
inline void GatherNodalSums(const TledModel<T>& model, const std::array<const T*, N>& forces, int a,
                            const std::array<T*, N>& sums) {
  constexpr int W = TledModel<T>::kLanes;
  const int32_t* offsets = model.gather_offsets().data();
  const int begin = model.gather_begin()[a], end = model.gather_begin()[a + 1];
  T even[N][3] = {}, odd[N][3] = {};
  int k = begin;
  for (; k + 1 < end; k += 2) {
    for (size_t i = 0; i < N; ++i) {
      const T* first = forces[i] + offsets[k];
      const T* second = forces[i] + offsets[k + 1];
      for (int axis = 0; axis < 3; ++axis) {
        even[i][axis] += first[axis * W];
        odd[i][axis] += second[axis * W];
      }
    }
  }
  for (size_t i = 0; i < N; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      if (k < end) even[i][axis] += forces[i][offsets[k] + axis * W];
      sums[i][axis] = even[i][axis] + odd[i][axis];
    }
  }
}

// Sum of the element forces at node a, in the model's fixed order (deterministic).
template <typename T>
inline void GatherNodalForce(const TledModel<T>& model, const T* forces, int a, T* f) {
  GatherNodalSums<T, 1>(model, {forces}, a, {f});
}

// The nodal forces of the chunk of nodes [begin, end), 3 per node: `gathered`
// when the caller gathered them already (GatherNodalForces for both sides of
// a coupled step at once), else gathered here into `own` (room for 3 (end - begin)).
template <typename T>
inline const T* ChunkNodalForces(const TledModel<T>& model, const T* forces, int begin, int end, const T* gathered,
                                 T* own) {
  if (gathered) return gathered;
  for (int a = begin; a < end; ++a) GatherNodalForce(model, forces, a, &own[3 * (a - begin)]);
  return own;
}

// GatherNodalForce of two force arrays in one walk over node a's incidences,
// each summed in the same order as GatherNodalForce (bitwise the same sums):
// one loop's control and offsets serve both, and the chains overlap.
template <typename T>
inline void GatherNodalForces(const TledModel<T>& model, const T* forces_a, const T* forces_b, int a, T* f_a,
                              T* f_b) {
  GatherNodalSums<T, 2>(model, {forces_a, forces_b}, a, {f_a, f_b});
}

// x^(-1/3) for x > 0, branch-free so the element loop vectorises: a bit-level
// first guess (exponent divided by three) refined by Newton's iteration
// y <- y (4 - x y^3) / 3, whose error squares each time; agrees with
// std::pow(x, -1/3) to round-off over [1e-12, 1e12].
template <typename T>
T InverseCubeRoot(T x);

}  // namespace dg::sim
