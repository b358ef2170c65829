#pragma once

#include <cstdint>
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
// Layout, for SIMD: elements are grouped in blocks of kLanes (one 64-byte
// register of T); within a block every quantity is stored lane-contiguous
// ("structure of arrays"), so the kernel computes kLanes elements per
// instruction. Elements are ordered by their smallest node id so that a
// block's nodes lie close together in memory; the last block is padded with
// zero-volume elements on node 0, which produce no force. Only dN/dX of corners
// 1..3 are stored: dN0/dX = -(dN1 + dN2 + dN3)/dX since the shape functions sum to one.
//
// Thread-safe to share read-only between any number of solvers.
template <typename T>
class TledModel {
 public:
  static constexpr int kLanes = static_cast<int>(64 / sizeof(T));

  // @throws dg::Error for an invalid material or a degenerate/inverted element.
  TledModel(const TetMesh& mesh, const Material& material);

  const TetMesh& mesh() const { return mesh_; }
  const Material& material() const { return material_; }
  int num_nodes() const { return mesh_.num_nodes(); }
  int num_tets() const { return mesh_.num_tets(); }
  int num_blocks() const { return num_blocks_; }
  T shear_modulus() const { return static_cast<T>(material_.shear_modulus_pa()); }
  T bulk_modulus() const { return static_cast<T>(material_.bulk_modulus_pa()); }

  // Node ids of block b: [corner][lane].
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

  // Size of the element-major force array the kernel writes: [block][corner][xyz][lane].
  size_t force_array_size() const { return size_t(num_blocks_) * 12 * kLanes; }
  // Node a's incidences are gather_offsets()[gather_begin()[a] .. gather_begin()[a+1]):
  // each the index of that corner's x force in the force array (y at +kLanes, z at +2 kLanes).
  const std::vector<int32_t>& gather_begin() const { return gather_begin_; }
  const std::vector<int32_t>& gather_offsets() const { return gather_offsets_; }

  // Lumped nodal mass, rho V0 / 4 from each element of the node, kg.
  const std::vector<double>& lumped_mass_kg() const { return mass_kg_; }

 private:
  TetMesh mesh_;
  Material material_;
  int num_blocks_ = 0;
  AlignedVector<int32_t> nodes_;
  AlignedVector<T> dN_dX_;
  AlignedVector<T> volume_m3_;
  AlignedVector<T> edges_m_;
  std::vector<int32_t> gather_begin_;
  std::vector<int32_t> gather_offsets_;
  std::vector<double> mass_kg_;
};

extern template class TledModel<float>;
extern template class TledModel<double>;

}  // namespace dg::sim
