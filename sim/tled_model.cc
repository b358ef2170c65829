#include "sim/tled_model.h"

#include <algorithm>
#include <numeric>

#include <Eigen/Dense>

#include "sim/error.h"

namespace dg::sim {

template <typename T>
TledModel<T>::TledModel(const TetMesh& mesh, const Material& material)
    : mesh_(mesh), material_(material) {
  if (const std::string problem = material.Validate(); !problem.empty()) {
    throw Error("invalid material: " + problem, "material", "correct the material parameters");
  }
  OrientElements(&mesh_, Orientation::kReject);
  if (mesh_.num_nodes() > (1 << 29)) {
    throw Error("mesh too large for 32-bit gather offsets", mesh_.source, "split the mesh");
  }
  layout_mesh_.X_m = mesh_.X_m;
  layout_mesh_.tets = mesh_.tets;
  layout_mesh_.source = mesh_.source;
  layout_mesh_.element_tags = mesh_.element_tags;  // element ids are the mesh's in both
  layout_mesh_.element_lines = mesh_.element_lines;
  layout_of_node_ = RenumberNodesForLocality(&layout_mesh_);
  node_of_layout_.resize(layout_of_node_.size());
  for (size_t a = 0; a < layout_of_node_.size(); ++a) node_of_layout_[layout_of_node_[a]] = static_cast<int>(a);
  const TetMesh& layout = layout_mesh_;

  // Elements in order of their smallest node: neighbours in memory share nodes.
  const int E = layout.num_tets();
  std::vector<int> order(E);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return layout.tets.col(a).minCoeff() < layout.tets.col(b).minCoeff();
  });

  num_blocks_ = (E + kLanes - 1) / kLanes;
  const size_t slots = size_t(num_blocks_) * kLanes;
  nodes_.assign(slots * 4, 0);
  dN_dX_.assign(slots * 9, T(0));
  volume_m3_.assign(slots, T(0));
  edges_m_.assign(slots * 9, T(0));
  mass_kg_.assign(layout.num_nodes(), 0.0);

  for (size_t slot = 0; slot < size_t(E); ++slot) {
    const int e = order[slot];
    const size_t b = slot / kLanes, l = slot % kLanes;
    // dN/dX from the inverse of the reference edge matrix: for linear shape
    // functions, [dN1; dN2; dN3] = (X1-X0, X2-X0, X3-X0)^-1 (rows: corners).
    Eigen::Matrix3d edges;
    for (int c = 0; c < 3; ++c) edges.col(c) = layout.X_m.col(layout.tets(c + 1, e)) - layout.X_m.col(layout.tets(0, e));
    const double volume = edges.determinant() / 6.0;
    const Eigen::Matrix3d dN = edges.inverse();  // row c: dN_{c+1}/dX
    for (int c = 0; c < 4; ++c) nodes_[(b * 4 + c) * kLanes + l] = layout.tets(c, e);
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < 3; ++j) {
        dN_dX_[(b * 9 + c * 3 + j) * kLanes + l] = static_cast<T>(dN(c, j));
        edges_m_[(b * 9 + c * 3 + j) * kLanes + l] = static_cast<T>(edges(j, c));
      }
    }
    volume_m3_[b * kLanes + l] = static_cast<T>(volume);
    for (int c = 0; c < 4; ++c) mass_kg_[layout.tets(c, e)] += material_.density_kg_m3 * volume / 4.0;
  }

  // Gather list: each node's incidences in the order of their place in the
  // force array (a fixed summation order, read front to back).
  std::vector<int> slot_of_element(E);
  for (int slot = 0; slot < E; ++slot) slot_of_element[order[slot]] = slot;
  const NodeIncidence incidence = BuildNodeIncidence(layout);
  gather_begin_.assign(incidence.offsets.begin(), incidence.offsets.end());
  gather_offsets_.resize(incidence.elements.size());
  for (size_t k = 0; k < incidence.elements.size(); ++k) {
    const size_t slot = slot_of_element[incidence.elements[k]];
    const size_t b = slot / kLanes, l = slot % kLanes;
    gather_offsets_[k] = static_cast<int32_t>((b * 12 + incidence.corners[k] * 3) * kLanes + l);
  }
  for (int a = 0; a < layout.num_nodes(); ++a) {
    std::sort(gather_offsets_.begin() + gather_begin_[a], gather_offsets_.begin() + gather_begin_[a + 1]);
  }
  for (int a = 0; a < layout.num_nodes(); ++a) {
    if (mass_kg_[a] <= 0) {
      throw Error("node " + std::to_string(node_of_layout_[a]) + " belongs to no element and has no mass", mesh_.source,
                  "remove unused nodes (dg::sim::RemoveUnusedNodes) before simulating");
    }
  }
}

template class TledModel<float>;
template class TledModel<double>;

}  // namespace dg::sim
