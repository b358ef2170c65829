#include "sim/subdomains.h"

#include <algorithm>
#include <random>
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
// elements with a node in its range, each once, in the order of their
// smallest node; its bounds are whole granules; the parts' lists are even.
TEST_CASE("subdomains: each part holds exactly the elements that touch its nodes", "[sim][unit]") {
  const TetMesh mesh = LayoutBox();
  constexpr int kGranule = 32;
  for (int parts : {1, 2, 3}) {
    const Subdomains split = SplitIntoSubdomains(mesh, parts, kGranule);
    REQUIRE(split.node_begin.size() == size_t(parts) + 1);
    REQUIRE(split.node_begin.front() == 0);
    REQUIRE(split.node_begin.back() == mesh.num_nodes());
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
      std::vector<int> smallest;
      for (int e : got) smallest.push_back(mesh.tets.col(e).minCoeff());
      CHECK(std::is_sorted(smallest.begin(), smallest.end()));
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
// the same order as a model of one: the nodal forces are bitwise the same.
TEST_CASE("subdomains: a model of two parts gives bitwise the forces of one", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(14, 12, 10, {0.05, 0.04, 0.03}, 0.3);
  const TledModel<float> one(mesh, Material{}, 1), two(mesh, Material{}, 2);
  REQUIRE(one.parts() == 1);
  REQUIRE(two.parts() == 2);
  REQUIRE(two.num_blocks() > one.num_blocks());
  REQUIRE(two.lumped_mass_kg() == one.lumped_mass_kg());
  REQUIRE(two.gather_begin() == one.gather_begin());
  std::mt19937 random(3);
  std::uniform_real_distribution<float> displacement(-2e-4f, 2e-4f);
  std::vector<float> u(3 * size_t(mesh.num_nodes()));
  for (float& value : u) value = displacement(random);  // layout order; the same for both models
  auto nodal_forces = [&](const TledModel<float>& model) {
    AlignedVector<float> forces(model.force_array_size());
    ComputeElementForces(model, u.data(), forces.data(), 0, model.num_blocks());
    std::vector<float> f(u.size());
    for (int a = 0; a < model.num_nodes(); ++a) GatherNodalForce(model, forces.data(), a, &f[3 * a]);
    return f;
  };
  const std::vector<float> f_one = nodal_forces(one);
  CHECK(*std::max_element(f_one.begin(), f_one.end()) > 0);
  CHECK(nodal_forces(two) == f_one);
}

}  // namespace
}  // namespace dg::sim
