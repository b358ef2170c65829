#include "sim/subdomains.h"

#include <algorithm>
#include <random>
#include <span>
#include <utility>
#include <set>

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include "sim/aligned_vector.h"
#include "sim/tled_kernel.h"
#include "sim/tled_model.h"
#include "tests/sim/box_mesh.h"

namespace dg::sim {
namespace {

using testing::MakeBoxMesh;

// A jittered box in layout order, as the model splits it.
TetMesh LayoutBox() {
  TetMesh mesh = MakeBoxMesh(14, 12, 10, {0.05, 0.04, 0.03}, 0.3);
  RenumberNodesForLocality(&mesh);
  return mesh;
}

// Against a brute-force reading of the definition: part w holds exactly the
// elements with a node in its range, each once, first those with all their
// nodes in it, then the halo, each group in the order of their smallest node;
// its bounds are whole granules; the parts' lists are even.
TEST_CASE("subdomains: each part holds exactly the elements that touch its nodes", "[sim][unit]") {
  const TetMesh mesh = LayoutBox();
  constexpr int kGranule = 32;
  for (int parts : {1, 2, 3}) {
    const Subdomains split = SplitIntoSubdomains(mesh, parts, kGranule);
    REQUIRE(split.node_begin.size() == size_t(parts) + 1);
    REQUIRE(split.node_begin.front() == 0);
    REQUIRE(split.node_begin.back() == mesh.num_nodes());
    // All elements, by smallest node, then id.
    REQUIRE(split.order.size() == size_t(mesh.num_tets()));
    for (size_t k = 1; k < split.order.size(); ++k) {
      const int before = split.order[k - 1], after = split.order[k];
      const int smallest_before = mesh.tets.col(before).minCoeff(), smallest_after = mesh.tets.col(after).minCoeff();
      CHECK((smallest_before < smallest_after || (smallest_before == smallest_after && before < after)));
    }
    size_t listed = 0, largest_part = 0;
    for (int w = 0; w < parts; ++w) {
      const int first = split.node_begin[w], end = split.node_begin[w + 1];
      REQUIRE(first < end);
      REQUIRE(first % kGranule == 0);
      std::vector<int> expected;
      for (int e = 0; e < mesh.num_tets(); ++e) {
        bool touches = false;
        for (int c = 0; c < 4; ++c) touches |= mesh.tets(c, e) >= first && mesh.tets(c, e) < end;
        if (touches) expected.push_back(e);
      }
      std::vector<int> got = split.elements[w];
      auto in_range = [&](int e) {
        int owned = 0;
        for (int c = 0; c < 4; ++c) owned += mesh.tets(c, e) >= first && mesh.tets(c, e) < end;
        return owned == 4;
      };
      const auto halo = std::partition_point(got.begin(), got.end(), in_range);
      CHECK(std::none_of(halo, got.end(), in_range));
      CHECK((parts == 1) == (halo == got.end()));
      for (auto group : {std::pair(got.begin(), halo), std::pair(halo, got.end())}) {
        std::vector<int> smallest;
        for (auto e = group.first; e != group.second; ++e) smallest.push_back(mesh.tets.col(*e).minCoeff());
        CHECK(std::is_sorted(smallest.begin(), smallest.end()));
      }
      std::sort(got.begin(), got.end());
      CHECK(got == expected);
      listed += got.size();
      largest_part = std::max(largest_part, got.size());
    }
    // The halo, elements listed twice: on this 10,080-element box 14% for two
    // parts and 26% for three (a regression bound on the cuts' quality).
    const double halo = double(listed) / mesh.num_tets() - 1;
    CHECK(halo <= 0.3 * (parts - 1));
    // Bounds move in granules of 32 nodes (about 150 elements here, and a
    // middle part carries two halos): no part exceeds an even share of the
    // lists by more than two granules' elements.
    CHECK(largest_part <= listed / parts + 2 * size_t(mesh.num_tets()) * kGranule / mesh.num_nodes());
  }
}

// A model of two parts sums every node's forces from the same elements in
// the same order as a model of one: the nodal forces are bitwise the same,
// node for node, though the two parts' models number their nodes differently
// (the cut nodes at the parts' ends).
TEST_CASE("subdomains: a model of two parts gives bitwise the forces of one", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(14, 12, 10, {0.05, 0.04, 0.03}, 0.3);
  const TledModel<float> one(mesh, Material{}, 1), two(mesh, Material{}, 2);
  REQUIRE(one.parts() == 1);
  REQUIRE(two.parts() == 2);
  REQUIRE(two.num_blocks() > one.num_blocks());
  for (int node = 0; node < mesh.num_nodes(); ++node) {
    const int a1 = one.layout_node(node), a2 = two.layout_node(node);
    REQUIRE(two.lumped_mass_kg()[a2] == one.lumped_mass_kg()[a1]);
    REQUIRE(two.gather_begin()[a2 + 1] - two.gather_begin()[a2] == one.gather_begin()[a1 + 1] - one.gather_begin()[a1]);
  }
  std::mt19937 random(3);
  std::uniform_real_distribution<float> displacement(-2e-4f, 2e-4f);
  std::vector<float> u(3 * size_t(mesh.num_nodes()));
  for (float& value : u) value = displacement(random);  // mesh order
  auto nodal_forces = [&](const TledModel<float>& model) {
    std::vector<float> layout_u(u.size()), layout_f(u.size()), f(u.size());
    model.ToLayout(std::span<const float>(u), std::span<float>(layout_u));
    AlignedVector<float> forces(model.force_array_size());
    ComputeElementForces(model, layout_u.data(), forces.data(), 0, model.num_blocks());
    for (int a = 0; a < model.num_nodes(); ++a) GatherNodalForce(model, forces.data(), a, &layout_f[3 * a]);
    model.ToMeshOrder(std::span<const float>(layout_f), std::span<float>(f));
    return f;
  };
  const std::vector<float> f_one = nodal_forces(one);
  CHECK(*std::max_element(f_one.begin(), f_one.end()) > 0);
  CHECK(nodal_forces(two) == f_one);
}

// In a model of two parts the nodes each part reads of the other's come
// together at the ends of the two ranges: the cut's displacements fill as few
// cache lines as they can.
TEST_CASE("subdomains: the nodes on the cut sit together at the parts' ends", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(14, 12, 10, {0.05, 0.04, 0.03}, 0.3);
  const TledModel<float> model(mesh, Material{}, 2);
  REQUIRE(model.parts() == 2);
  const int cut = model.part_node_begin()[1];
  // Brute force: the nodes of part w's elements that part w does not own.
  std::vector<std::set<int>> read_from_other(2);
  for (int w = 0; w < 2; ++w) {
    for (int chunk = model.part_chunk_begin()[w]; chunk < model.part_chunk_begin()[w + 1]; ++chunk) {
      for (int b = model.chunk_block_begin(chunk); b < model.chunk_block_begin(chunk + 1); ++b) {
        for (int k = 0; k < 4 * TledModel<float>::kLanes; ++k) {
          const int a = model.block_nodes(b)[k];
          if ((a >= cut) != (w == 1)) read_from_other[w].insert(a);
        }
      }
    }
  }
  REQUIRE(!read_from_other[0].empty());
  REQUIRE(!read_from_other[1].empty());
  // Part 1 reads part 0's last nodes, every one of them; part 0 reads part 1's first.
  CHECK(*read_from_other[1].begin() == cut - int(read_from_other[1].size()));
  CHECK(*read_from_other[0].rbegin() == cut + int(read_from_other[0].size()) - 1);

  // The lines the model lists as crossing: of a per-node array (3 floats a
  // node, 16 a line), those holding a value of a node the part reads of the
  // other.
  auto lines_of = [](const std::set<int>& nodes) {
    std::vector<int32_t> lines;
    for (int a : nodes) {
      for (int value = 3 * a; value < 3 * a + 3; ++value) lines.push_back(value / 16 * 16);
    }
    std::sort(lines.begin(), lines.end());
    lines.erase(std::unique(lines.begin(), lines.end()), lines.end());
    return lines;
  };
  auto listed = [](std::span<const int32_t> lines) { return std::vector<int32_t>(lines.begin(), lines.end()); };
  for (int w = 0; w < 2; ++w) {
    CHECK(listed(model.halo_lines(w)) == lines_of(read_from_other[w]));
  }
  // Together, the nodes' 12 bytes each fill as few lines as they can, plus
  // one where a range starts inside a line.
  const size_t cut_nodes = read_from_other[0].size() + read_from_other[1].size();
  CHECK(model.halo_lines(0).size() + model.halo_lines(1).size() <= (12 * cut_nodes + 63) / 64 + 2);
}

}  // namespace
}  // namespace dg::sim
