#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sim/aligned_vector.h"
#include "sim/material.h"
#include "sim/tet_mesh.h"

namespace dg::sim {

// The precomputed, immutable part of a TLED simulation (Miller et al. 2007):
// per element the reference volume V0 and shape-function derivatives dN/dX,
// per node the lumped mass, and the node -> element-corner gather list.
// Geometry is computed in double and stored in the kernel's scalar T.
//
// Layout order: whatever order the mesh's nodes come in (a file's, a
// mesher's), the model numbers them along a Morton curve through their
// reference positions (layout_mesh()), so that nodes close in space are close
// in memory and a thread's contiguous range of nodes is a compact region.
// Every per-node array of the model and of the kernels (lumped masses, gather
// lists, the displacements and forces they take) is in layout order; the
// classes built on the model (TledSolver, CoupledSimulation, ForceRecovery,
// ForceResolution) take and give the mesh's own order, converting with
// ToLayout() and ToMeshOrder(). Element ids are the mesh's in both.
//
// Blocks, for SIMD: elements are grouped in blocks of kLanes (one 64-byte
// register of T); within a block every quantity is stored lane-contiguous
// ("structure of arrays"), so the kernel computes kLanes elements per
// instruction. Elements are ordered by their smallest node on the Morton
// curve so that a block's nodes lie close together in memory; a part's last
// block is padded with zero-volume elements on the part's first node, which
// produce no force. Only dN/dX of corners 1..3 are stored:
// dN0/dX = -(dN1 + dN2 + dN3)/dX since the shape functions sum to one.
//
// Parts, for threads (docs/solver.md, "Subdomains"): the layout nodes are cut
// into `parts` ranges, one per worker of a step team, and each part's blocks
// hold every element that touches its nodes, so that the elements on a cut
// appear once in each part they touch (the halo). A node gathers only from its
// own part's copies: the forces a worker sums are the ones it computed. The
// nodes that other parts read then move to their part's ends, so that what
// crosses between cores fills few cache lines, and each part lists its halo
// after its interior, so that a worker reads them last. A node still sums its
// forces in the order of all elements above, for any number of parts. With
// one part the layout is the plain Morton one.
//
// Thread-safe to share read-only between any number of solvers.

// Blocks per unit of parallel work in the element passes, and nodes per unit
// in the node passes. Partial results (smallest J, kinetic energy) are kept
// per chunk, so they combine in the same order whatever the thread count.
constexpr int kBlocksPerChunk = 8;
constexpr int kNodesPerChunk = 32;

template <typename T>
class TledModel {
 public:
  static constexpr int kLanes = static_cast<int>(64 / sizeof(T));

  // `parts`: one per worker of the step teams that will run it, 0 for the
  // process's default team size (DefaultTeamSize()); fewer on a mesh of
  // fewer than `parts` node chunks. Any team can run any model: a model of
  // fewer parts than workers only shares more forces between cores.
  // @throws dg::Error for an invalid material or a degenerate/inverted element.
  TledModel(const TetMesh& mesh, const Material& material, int parts = 0);

  // The mesh as given (oriented), in its own node order.
  const TetMesh& mesh() const { return mesh_; }
  // The same mesh with its nodes in layout order (no node or element sets).
  const TetMesh& layout_mesh() const { return layout_mesh_; }
  int layout_node(int node) const { return layout_of_node_[node]; }
  int mesh_node(int layout_node) const { return node_of_layout_[layout_node]; }
  // mesh_node() of every layout node, in layout order.
  std::span<const int> mesh_nodes_in_layout_order() const { return node_of_layout_; }
  // Per-node values (3 per node, xyz) from the mesh's node order into layout
  // order, and back. @pre both spans hold 3 num_nodes() values
  template <typename In, typename Out>
  void ToLayout(std::span<const In> values, std::span<Out> layout) const;
  template <typename In, typename Out>
  void ToMeshOrder(std::span<const In> layout, std::span<Out> values) const;
  const Material& material() const { return material_; }
  int num_nodes() const { return mesh_.num_nodes(); }
  int num_tets() const { return mesh_.num_tets(); }
  int num_blocks() const { return num_blocks_; }
  T shear_modulus() const { return static_cast<T>(material_.shear_modulus_pa()); }
  T bulk_modulus() const { return static_cast<T>(material_.bulk_modulus_pa()); }

  // Layout node ids of block b: [corner][lane].
  const int32_t* block_nodes(int b) const { return nodes_.data() + size_t(b) * 4 * kLanes; }
  // dN/dX of corners 1..3 of block b: [corner - 1][dimension][lane], 1/m.
  const T* block_shape_gradients(int b) const { return dN_dX_.data() + size_t(b) * 9 * kLanes; }
  // Reference volumes of block b: [lane], m^3 (0 for padding).
  const T* block_volumes(int b) const { return volume_m3_.data() + size_t(b) * kLanes; }
  // Reference edges X_j - X_0 (j = 1..3) of block b: [j - 1][xyz][lane], m, computed in
  // double and rounded once (edges of millimetres taken from float positions of
  // centimetres would lose three digits); zero for padding. With a displacement
  // difference u_j - u_0 added, the edges of any deformed geometry (force resolution).
  const T* block_reference_edges(int b) const { return edges_m_.data() + size_t(b) * 9 * kLanes; }

  // Part w owns layout nodes [part_node_begin()[w], part_node_begin()[w + 1])
  // (whole node chunks) and element chunks [part_chunk_begin()[w], part_chunk_begin()[w + 1]).
  int parts() const { return static_cast<int>(part_node_begin_.size()) - 1; }
  std::span<const int> part_node_begin() const { return part_node_begin_; }
  std::span<const int> part_chunk_begin() const { return part_chunk_begin_; }
  // Element chunk c is blocks [chunk_block_begin(c), chunk_block_begin(c + 1)).
  int element_chunks() const { return static_cast<int>(chunk_block_begin_.size()) - 1; }
  int chunk_block_begin(int c) const { return chunk_block_begin_[c]; }

  // The 64-byte lines of a per-node array (3 values of T a node, 64-byte
  // aligned, layout order) that hold nodes part w's elements read and
  // another part owns, each as the offset of its first value, ascending
  // (docs/solver.md, "Subdomains"). A part's node range starts on a line, so
  // each line has one owner. Empty for a model of one part.
  std::span<const int32_t> halo_lines(int w) const { return halo_lines_[w]; }

  // Size of the element-major force array the kernel writes: [block][corner][xyz][lane].
  size_t force_array_size() const { return size_t(num_blocks_) * 12 * kLanes; }
  // Layout node a's incidences are gather_offsets()[gather_begin()[a] .. gather_begin()[a+1]):
  // each the index of that corner's x force in the force array (y at +kLanes, z at +2 kLanes).
  const std::vector<int32_t>& gather_begin() const { return gather_begin_; }
  const std::vector<int32_t>& gather_offsets() const { return gather_offsets_; }

  // Lumped nodal mass, rho V0 / 4 from each element of the node, kg, in layout order.
  const std::vector<double>& lumped_mass_kg() const { return mass_kg_; }

 private:
  TetMesh mesh_;
  TetMesh layout_mesh_;
  std::vector<int> layout_of_node_, node_of_layout_;
  Material material_;
  int num_blocks_ = 0;
  std::vector<int> part_node_begin_, part_chunk_begin_, chunk_block_begin_;
  AlignedVector<int32_t> nodes_;
  AlignedVector<T> dN_dX_;
  AlignedVector<T> volume_m3_;
  AlignedVector<T> edges_m_;
  std::vector<int32_t> gather_begin_;
  std::vector<int32_t> gather_offsets_;
  std::vector<double> mass_kg_;
  std::vector<std::vector<int32_t>> halo_lines_;  // per part
};

// Per-node values (3 per node) from `from` into `to`, node k going to node destination[k].
template <typename In, typename Out>
void ScatterNodes(std::span<const In> from, std::span<Out> to, const std::vector<int>& destination) {
  for (size_t k = 0; k < destination.size(); ++k) {
    const size_t d = destination[k];
    for (int i = 0; i < 3; ++i) to[3 * d + i] = static_cast<Out>(from[3 * k + i]);
  }
}

template <typename T>
template <typename In, typename Out>
void TledModel<T>::ToLayout(std::span<const In> values, std::span<Out> layout) const {
  ScatterNodes(values, layout, layout_of_node_);
}

template <typename T>
template <typename In, typename Out>
void TledModel<T>::ToMeshOrder(std::span<const In> layout, std::span<Out> values) const {
  ScatterNodes(layout, values, node_of_layout_);
}

extern template class TledModel<float>;
extern template class TledModel<double>;

}  // namespace dg::sim
