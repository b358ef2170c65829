#include "sim/tled_model.h"

#include <algorithm>
#include <numeric>

#include <Eigen/Dense>

#include "sim/error.h"
#include "sim/step_team.h"
#include "sim/subdomains.h"

namespace dg::sim {
namespace {

// A new place for every layout node that keeps each part's nodes in their
// range and their order, except that the nodes other parts read come together
// at the range's ends: those read by lower parts first, those read by higher
// parts last. The displacements that cross between cores each step then fill
// few cache lines, next to the neighbour's (docs/solver.md, "Subdomains").
std::vector<int> CutNodesTogether(const TetMesh& layout, const Subdomains& split) {
  const int parts = static_cast<int>(split.elements.size());
  std::vector<int> owner(layout.num_nodes());
  for (int w = 0; w < parts; ++w) {
    std::fill(owner.begin() + split.node_begin[w], owner.begin() + split.node_begin[w + 1], w);
  }
  // Bit 0: read by a lower part; bit 1: read by a higher part.
  std::vector<int> readers(layout.num_nodes(), 0);
  for (int w = 0; w < parts; ++w) {
    for (int e : split.elements[w]) {
      for (int c = 0; c < 4; ++c) {
        const int a = layout.tets(c, e);
        if (owner[a] != w) readers[a] |= w < owner[a] ? 1 : 2;
      }
    }
  }
  auto group = [&](int a) { return readers[a] & 1 ? 0 : readers[a] == 0 ? 1 : 2; };
  std::vector<int> place(layout.num_nodes());
  for (int w = 0; w < parts; ++w) {
    int next = split.node_begin[w];
    for (int g = 0; g < 3; ++g) {
      for (int a = split.node_begin[w]; a < split.node_begin[w + 1]; ++a) {
        if (group(a) == g) place[a] = next++;
      }
    }
  }
  return place;
}

// The lines of a 64-byte aligned per-node array (3 values of T a node) that
// hold node a's values, each as the offset of its first value.
template <typename T>
void AddLinesOfNode(int a, std::vector<int32_t>* lines) {
  constexpr int kValuesPerLine = 64 / sizeof(T);
  const int32_t first = 3 * a / kValuesPerLine, last = (3 * a + 2) / kValuesPerLine;
  for (int32_t line = first; line <= last; ++line) lines->push_back(line * kValuesPerLine);
}

// Moves layout node a to place[a].
void RenumberNodes(TetMesh* mesh, const std::vector<int>& place) {
  Eigen::Matrix3Xd X(3, mesh->num_nodes());
  for (int a = 0; a < mesh->num_nodes(); ++a) X.col(place[a]) = mesh->X_m.col(a);
  mesh->X_m = std::move(X);
  for (int e = 0; e < mesh->num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) mesh->tets(c, e) = place[mesh->tets(c, e)];
  }
}

}  // namespace

template <typename T>
TledModel<T>::TledModel(const TetMesh& mesh, const Material& material, int parts)
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

  // Blocks: each part's elements (its own and its halo, in order of their
  // smallest node, so that a block's lanes share nodes), padded to whole
  // blocks with zero-volume elements on the part's first node, and cut into
  // chunks that stay inside the part. The element order is fixed on the
  // space-filling order, before the cut nodes move: it is the order in which
  // a node sums its elements, the same for any number of parts.
  const Subdomains split = SplitIntoSubdomains(layout_mesh_, parts > 0 ? parts : DefaultTeamSize(), kNodesPerChunk);
  if (split.elements.size() > 1) {
    const std::vector<int> place = CutNodesTogether(layout_mesh_, split);
    RenumberNodes(&layout_mesh_, place);
    for (int& a : layout_of_node_) a = place[a];
  }
  node_of_layout_.resize(layout_of_node_.size());
  for (size_t a = 0; a < layout_of_node_.size(); ++a) node_of_layout_[layout_of_node_[a]] = static_cast<int>(a);
  const TetMesh& layout = layout_mesh_;
  part_node_begin_ = split.node_begin;
  std::vector<int> slot_element;  // -1: padding
  std::vector<int> part_of_slot;
  part_chunk_begin_ = {0};
  chunk_block_begin_ = {0};
  for (size_t w = 0; w < split.elements.size(); ++w) {
    const std::vector<int>& elements = split.elements[w];
    const int blocks = static_cast<int>((elements.size() + kLanes - 1) / kLanes);
    slot_element.insert(slot_element.end(), elements.begin(), elements.end());
    slot_element.resize(slot_element.size() + size_t(blocks) * kLanes - elements.size(), -1);
    part_of_slot.resize(slot_element.size(), static_cast<int>(w));
    const int first_block = chunk_block_begin_.back();
    for (int b = kBlocksPerChunk; b < blocks; b += kBlocksPerChunk) chunk_block_begin_.push_back(first_block + b);
    if (blocks > 0) chunk_block_begin_.push_back(first_block + blocks);
    part_chunk_begin_.push_back(static_cast<int>(chunk_block_begin_.size()) - 1);
  }

  num_blocks_ = chunk_block_begin_.back();
  const size_t slots = size_t(num_blocks_) * kLanes;
  nodes_.assign(slots * 4, 0);
  dN_dX_.assign(slots * 9, T(0));
  volume_m3_.assign(slots, T(0));
  edges_m_.assign(slots * 9, T(0));
  mass_kg_.assign(layout.num_nodes(), 0.0);
  std::vector<double> element_volume(layout.num_tets());

  for (size_t slot = 0; slot < slots; ++slot) {
    const size_t b = slot / kLanes, l = slot % kLanes;
    const int e = slot_element[slot];
    if (e < 0) {
      for (int c = 0; c < 4; ++c) nodes_[(b * 4 + c) * kLanes + l] = part_node_begin_[part_of_slot[slot]];
      continue;
    }
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
    element_volume[e] = volume;
  }

  // Masses and gather lists take the elements in the order of all elements
  // (by smallest node, then id), whatever the parts and wherever a part
  // places an element: a node sums the same elements in the same order for
  // any number of parts, so results do not depend on the parts, nor so on the
  // team size the model was built for. A node gathers from its own part's
  // copies of its elements.
  for (int e : split.order) {
    for (int c = 0; c < 4; ++c) mass_kg_[layout.tets(c, e)] += material_.density_kg_m3 * element_volume[e] / 4.0;
  }
  std::vector<int> rank(layout.num_tets());
  for (size_t k = 0; k < split.order.size(); ++k) rank[split.order[k]] = static_cast<int>(k);
  std::vector<size_t> slots_in_order;
  for (size_t slot = 0; slot < slots; ++slot) {
    if (slot_element[slot] >= 0) slots_in_order.push_back(slot);
  }
  std::stable_sort(slots_in_order.begin(), slots_in_order.end(),
                   [&](size_t x, size_t y) { return rank[slot_element[x]] < rank[slot_element[y]]; });
  auto owns = [&](size_t slot, int node) {
    const int w = part_of_slot[slot];
    return node >= part_node_begin_[w] && node < part_node_begin_[w + 1];
  };
  gather_begin_.assign(layout.num_nodes() + 1, 0);
  for (size_t slot : slots_in_order) {
    for (int c = 0; c < 4; ++c) {
      const int a = layout.tets(c, slot_element[slot]);
      if (owns(slot, a)) ++gather_begin_[a + 1];
    }
  }
  std::partial_sum(gather_begin_.begin(), gather_begin_.end(), gather_begin_.begin());
  gather_offsets_.resize(gather_begin_.back());
  std::vector<int32_t> filled(gather_begin_.begin(), gather_begin_.end() - 1);
  for (size_t slot : slots_in_order) {
    const size_t b = slot / kLanes, l = slot % kLanes;
    for (int c = 0; c < 4; ++c) {
      const int a = layout.tets(c, slot_element[slot]);
      if (owns(slot, a)) gather_offsets_[filled[a]++] = static_cast<int32_t>((b * 12 + c * 3) * kLanes + l);
    }
  }
  // The lines that cross between parts: each part's corners on another's nodes.
  halo_lines_.resize(split.elements.size());
  for (size_t slot = 0; slot < slots; ++slot) {
    if (slot_element[slot] < 0) continue;
    const int w = part_of_slot[slot];
    for (int c = 0; c < 4; ++c) {
      const int a = layout.tets(c, slot_element[slot]);
      if (!owns(slot, a)) AddLinesOfNode<T>(a, &halo_lines_[w]);
    }
  }
  for (std::vector<int32_t>& lines : halo_lines_) {
    std::sort(lines.begin(), lines.end());
    lines.erase(std::unique(lines.begin(), lines.end()), lines.end());
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
