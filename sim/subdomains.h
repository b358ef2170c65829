#pragma once

#include <vector>

#include "sim/tet_mesh.h"

namespace dg::sim {

// An owner-computes split of a mesh for a team of workers (docs/solver.md,
// "Subdomains"): part w owns the nodes [node_begin[w], node_begin[w + 1]) and
// lists every element that touches one of them, its own elements and the
// halo it shares with its neighbours. A worker that computes its part's
// elements has every force its nodes gather: no force crosses between cores,
// at the price of computing the halo elements twice.
//
// Each part lists the elements that touch only its own nodes first and its
// halo last, so that a worker reads the nodes other cores wrote at the end
// of its pass, once what it asked for early has arrived (docs/solver.md,
// "Subdomains"). Both groups keep the order of all elements, `order`.
struct Subdomains {
  std::vector<int> node_begin;            // parts + 1 bounds, ascending, the last num_nodes
  std::vector<std::vector<int>> elements;  // per part: its interior, then its halo
  // Every element, by smallest node, then id: the order in which a node sums
  // the forces of its elements, whatever the number of parts.
  std::vector<int> order;
};

// Splits `mesh` (nodes in layout order, so that a range of nodes is a compact
// region) into at most `parts` parts whose node bounds are multiples of
// `node_granularity` and whose element lists (halo included) are as even as
// those bounds allow. Fewer parts when the mesh has fewer granules of nodes.
Subdomains SplitIntoSubdomains(const TetMesh& mesh, int parts, int node_granularity);

}  // namespace dg::sim
