#include "sim/tet_mesh.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include "sim/error.h"
#include "tests/sim/box_mesh.h"

namespace dg::sim {
namespace {

// The unit cube split into six positively oriented tetrahedra (Kuhn triangulation).
TetMesh KuhnCube() {
  TetMesh mesh;
  mesh.source = "Kuhn cube";
  mesh.X_m.resize(3, 8);
  for (int i = 0; i < 8; ++i) mesh.X_m.col(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  mesh.tets.resize(4, 6);
  mesh.tets << 0, 0, 0, 0, 0, 0,  //
      1, 1, 2, 2, 4, 4,           //
      3, 5, 3, 6, 5, 6,           //
      7, 7, 7, 7, 7, 7;
  return mesh;
}

}  // namespace

// Flipping two nodes of every element is undone; the total volume is the cube's.
TEST_CASE("tet_mesh: orientation repaired and volume preserved", "[sim][unit]") {
  TetMesh mesh = KuhnCube();
  const int already_negative = OrientElements(&mesh);
  double volume = 0;
  for (int e = 0; e < mesh.num_tets(); ++e) volume += SixSignedVolume(mesh, e) / 6.0;
  REQUIRE(volume == Approx(1.0).epsilon(1e-14));
  for (int e = 0; e < mesh.num_tets(); ++e) std::swap(mesh.tets(0, e), mesh.tets(1, e));
  REQUIRE(OrientElements(&mesh) == 6);
  for (int e = 0; e < mesh.num_tets(); ++e) REQUIRE(SixSignedVolume(mesh, e) > 0);
  (void)already_negative;
}

// An inverted element is refused by name under kReject.
TEST_CASE("tet_mesh: rejected inverted element names it", "[sim][unit]") {
  TetMesh mesh = KuhnCube();
  OrientElements(&mesh);
  std::swap(mesh.tets(2, 3), mesh.tets(3, 3));
  REQUIRE_THROWS_WITH(OrientElements(&mesh, Orientation::kReject),
                      Catch::Contains("element 3") && Catch::Contains("inverted"));
}

// The cube's boundary is 12 triangles of total area 6, all wound outward.
TEST_CASE("tet_mesh: boundary faces of a cube", "[sim][unit]") {
  TetMesh mesh = KuhnCube();
  OrientElements(&mesh);
  const Eigen::Matrix3Xi faces = BoundaryFaces(mesh);
  REQUIRE(faces.cols() == 12);
  double area = 0;
  const Eigen::Vector3d centre(0.5, 0.5, 0.5);
  for (int f = 0; f < faces.cols(); ++f) {
    const Eigen::Vector3d a = mesh.X_m.col(faces(0, f)), b = mesh.X_m.col(faces(1, f)),
                          c = mesh.X_m.col(faces(2, f));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    area += 0.5 * n.norm();
    REQUIRE(n.dot(a - centre) > 0);
  }
  REQUIRE(area == Approx(6.0));
  REQUIRE(BoundaryNodes(mesh).size() == 8);
  REQUIRE(NodesNearPlane(mesh, {0, 0, 0}, {0, 0, 1}, 1e-9) == std::vector<int>{0, 1, 2, 3});
  REQUIRE(NodesInBox(mesh, {0.5, -1, -1}, {2, 2, 2}, 0) == std::vector<int>{1, 3, 5, 7});
}

}  // namespace dg::sim

namespace dg::sim {

// Renumbering is a permutation: positions, elements (as point sets) and node
// sets describe the same mesh, and neighbours in space become neighbours in memory.
TEST_CASE("tet_mesh: Morton renumbering keeps the mesh and improves locality", "[sim][unit]") {
  TetMesh mesh = testing::MakeBoxMesh(8, 8, 8, {0.01, 0.01, 0.01}, 0.2);
  // Scramble first so that the test does not depend on the generator's order.
  std::vector<int> scramble(mesh.num_nodes());
  for (int a = 0; a < mesh.num_nodes(); ++a) scramble[a] = (a * 7919) % mesh.num_nodes();
  TetMesh scrambled = mesh;
  for (int a = 0; a < mesh.num_nodes(); ++a) scrambled.X_m.col(scramble[a]) = mesh.X_m.col(a);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) scrambled.tets(c, e) = scramble[mesh.tets(c, e)];
  }
  auto spread = [](const TetMesh& m) {  // mean node-id range within an element
    double sum = 0;
    for (int e = 0; e < m.num_tets(); ++e) sum += m.tets.col(e).maxCoeff() - m.tets.col(e).minCoeff();
    return sum / m.num_tets();
  };
  TetMesh renumbered = scrambled;
  const std::vector<int> new_id = RenumberNodesForLocality(&renumbered);
  for (int a = 0; a < mesh.num_nodes(); ++a) REQUIRE(renumbered.X_m.col(new_id[a]) == scrambled.X_m.col(a));
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) REQUIRE(renumbered.tets(c, e) == new_id[scrambled.tets(c, e)]);
    REQUIRE(SixSignedVolume(renumbered, e) == Approx(SixSignedVolume(mesh, e)));
  }
  // Within half again of the grid's own lexicographic (banded) order, and far
  // from the scrambled one (a quarter of it here: 115 against 91 and 472).
  REQUIRE(spread(renumbered) < 1.5 * spread(mesh));
  REQUIRE(spread(renumbered) < 0.3 * spread(scrambled));
}

}  // namespace dg::sim
