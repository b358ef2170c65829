#include "io/gmsh_reader.h"

#include <algorithm>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::io {
namespace {

std::string Fixture(const std::string& name) {
  return std::string(DG_SOURCE_DIR) + "/tests/io/fixtures/" + name;
}

// Signed volume of element e from the node coordinates, by the triple product.
double TetVolume(const sim::TetMesh& mesh, int e) {
  const Eigen::Vector3d a = mesh.X_m.col(mesh.tets(0, e)), b = mesh.X_m.col(mesh.tets(1, e)),
                        c = mesh.X_m.col(mesh.tets(2, e)), d = mesh.X_m.col(mesh.tets(3, e));
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

double TotalVolume(const sim::TetMesh& mesh) {
  double volume = 0;
  for (int e = 0; e < mesh.num_tets(); ++e) volume += TetVolume(mesh, e);
  return volume;
}

void RequireSameMesh(const sim::TetMesh& a, const sim::TetMesh& b) {
  REQUIRE(a.num_nodes() == b.num_nodes());
  REQUIRE(a.num_tets() == b.num_tets());
  REQUIRE((a.X_m - b.X_m).cwiseAbs().maxCoeff() == 0.0);
  REQUIRE(a.tets == b.tets);
  REQUIRE(a.node_sets == b.node_sets);
  REQUIRE(a.element_sets == b.element_sets);
}

// The error ReadGmsh throws for a file (fails the test when there is none).
Error ReadError(const std::string& path) {
  try {
    ReadGmsh(path);
  } catch (const Error& error) {
    return error;
  }
  FAIL("no error reading " << path);
  throw;  // unreachable: FAIL throws
}

// Line number of the first element block header of `type` in a format 4.1
// file, found by walking the $Elements blocks.
int LineOfFirstBlockOfType(const std::string& path, const std::string& type) {
  std::ifstream in(path);
  std::string line;
  int number = 0;
  while (std::getline(in, line) && line != "$Elements") ++number;
  std::getline(in, line);  // section header
  number += 2;
  while (std::getline(in, line)) {
    ++number;
    std::istringstream block(line);
    std::string dim, entity, block_type;
    long count = 0;
    block >> dim >> entity >> block_type >> count;
    if (block_type == type) return number;
    for (long i = 0; i < count; ++i, ++number) std::getline(in, line);
  }
  return -1;
}

}  // namespace

// The same Gmsh model saved by gmsh as format 2.2, 4.1 and 4.1 with parametric
// coordinates reads to the same nodes (same order), elements and sets.
TEST_CASE("gmsh_reader: formats 2.2 and 4.1 read to the same mesh", "[io][unit]") {
  const sim::TetMesh v22 = ReadGmsh(Fixture("box_with_hole_v22.msh"));
  const sim::TetMesh v41 = ReadGmsh(Fixture("box_with_hole_v41.msh"));
  const sim::TetMesh parametric = ReadGmsh(Fixture("box_with_hole_v41_parametric.msh"));
  REQUIRE(v22.num_tets() == 536);  // gmsh's own count when it wrote the files
  RequireSameMesh(v22, v41);
  RequireSameMesh(v22, parametric);
  REQUIRE(v41.source == Fixture("box_with_hole_v41.msh"));

  const sim::TetMesh hand_v22 = ReadGmsh(Fixture("two_tets_sparse_v22.msh"));
  const sim::TetMesh hand_v41 = ReadGmsh(Fixture("two_tets_sparse_v41.msh"));
  RequireSameMesh(hand_v22, hand_v41);
}

// The mesh of a 40 x 30 x 20 mm box with a 10 x 10 mm through-hole has the
// analytic volume 22000 mm^3, in m^3 with metres_per_unit = 1e-3, and every
// element is positively oriented.
TEST_CASE("gmsh_reader: volume matches the geometry in metres", "[io][unit]") {
  const sim::TetMesh mesh = ReadGmsh(Fixture("box_with_hole_v41.msh"), 1e-3);
  REQUIRE(TotalVolume(mesh) == Approx(22000e-9).epsilon(1e-12));
  for (int e = 0; e < mesh.num_tets(); ++e) REQUIRE(TetVolume(mesh, e) > 0);
  REQUIRE(mesh.X_m.rowwise().minCoeff().isZero(1e-12));
  REQUIRE(mesh.X_m.rowwise().maxCoeff().isApprox(Eigen::Vector3d(0.04, 0.03, 0.02), 1e-12));
}

// Physical groups become sets whose nodes lie on their surfaces and cover
// them; the unnamed group gets its default name; the volume is also an
// element set of every tetrahedron.
TEST_CASE("gmsh_reader: physical groups become node and element sets", "[io][unit]") {
  const sim::TetMesh mesh = ReadGmsh(Fixture("box_with_hole_v22.msh"));
  std::set<std::string> node_set_names, element_set_names;
  for (const auto& [name, ids] : mesh.node_sets) node_set_names.insert(name);
  for (const auto& [name, ids] : mesh.element_sets) element_set_names.insert(name);
  REQUIRE(node_set_names ==
          std::set<std::string>{"body", "bottom", "hole", "origin", "physical_2_7", "top"});
  REQUIRE(element_set_names == std::set<std::string>{"body"});

  const auto count_where = [&](auto predicate) {
    int count = 0;
    for (int a = 0; a < mesh.num_nodes(); ++a) count += predicate(mesh.X_m.col(a)) ? 1 : 0;
    return count;
  };
  const auto on_hole = [](const Eigen::Vector3d& x) {
    const bool in_x = x.x() >= 15 && x.x() <= 25, in_y = x.y() >= 10 && x.y() <= 20;
    return (in_y && (x.x() == 15 || x.x() == 25)) || (in_x && (x.y() == 10 || x.y() == 20));
  };
  const auto bottom = [](const Eigen::Vector3d& x) { return x.z() == 0; };
  const auto top = [](const Eigen::Vector3d& x) { return x.z() == 20; };
  const auto left = [](const Eigen::Vector3d& x) { return x.x() == 0; };
  const std::pair<std::string, std::function<bool(const Eigen::Vector3d&)>> surfaces[] = {
      {"bottom", bottom}, {"top", top}, {"hole", on_hole}, {"physical_2_7", left}};
  for (const auto& [name, on_surface] : surfaces) {
    INFO(name);
    const std::vector<int>& ids = mesh.node_sets.at(name);
    REQUIRE(std::is_sorted(ids.begin(), ids.end()));
    for (int a : ids) REQUIRE(on_surface(mesh.X_m.col(a)));
    REQUIRE(static_cast<int>(ids.size()) == count_where(on_surface));
  }
  const std::vector<int>& origin = mesh.node_sets.at("origin");
  REQUIRE(origin.size() == 1);
  REQUIRE(mesh.X_m.col(origin[0]).isZero());
  REQUIRE(static_cast<int>(mesh.node_sets.at("body").size()) == mesh.num_nodes());
  REQUIRE(static_cast<int>(mesh.element_sets.at("body").size()) == mesh.num_tets());
  REQUIRE(mesh.element_sets.at("body").back() == mesh.num_tets() - 1);
}

// Sparse node tags map to ids in file order, the node no tetrahedron uses is
// dropped, and the element written inverted is reoriented: two tetrahedra of
// volumes 1/6 and 1/3.
TEST_CASE("gmsh_reader: sparse tags, unused node, inverted element", "[io][unit]") {
  const sim::TetMesh mesh = ReadGmsh(Fixture("two_tets_sparse_v22.msh"), 2.0);
  REQUIRE(mesh.num_nodes() == 5);
  REQUIRE(mesh.num_tets() == 2);
  Eigen::Matrix3Xd expected(3, 5);
  expected << 0, 1, 0, 0, 1,  //
      0, 0, 1, 0, 1,          //
      0, 0, 0, 1, 1;
  REQUIRE(mesh.X_m == 2.0 * expected);
  REQUIRE(mesh.tets.col(0) == Eigen::Vector4i(0, 1, 2, 3));
  REQUIRE(TetVolume(mesh, 0) == Approx(8.0 / 6));
  REQUIRE(TetVolume(mesh, 1) == Approx(8.0 / 3));
  REQUIRE(mesh.node_sets.at("base") == std::vector<int>{0, 1, 2});
  REQUIRE(mesh.node_sets.at("solid") == std::vector<int>{0, 1, 2, 3, 4});
  REQUIRE(mesh.element_sets.at("solid") == std::vector<int>{0, 1});
}

// Each malformed file is refused with an error at file:line of its defect,
// saying what is wrong and how to fix it.
TEST_CASE("gmsh_reader: malformed files name file and line", "[io][unit]") {
  struct Case {
    const char* file;
    int line;
    const char* problem;
  };
  const Case cases[] = {
      {"truncated_v22.msh", 21, "file ends inside the $Elements section"},
      {"bad_number_v22.msh", 13, "'1.0.5' is not a finite number"},
      {"unknown_node_v22.msh", 22, "refers to node 60"},
      {"wrong_node_count_v22.msh", 21, "should list 4 nodes but lists 3"},
      {"missing_elements_v22.msh", 17, "no $Elements section"},
      {"bad_number_v41.msh", 28, "'x5' is not a finite number"},
  };
  for (const Case& c : cases) {
    INFO(c.file);
    const Error error = ReadError(Fixture(c.file));
    REQUIRE(error.where() == Fixture(c.file) + ":" + std::to_string(c.line));
    REQUIRE_THAT(error.problem(), Catch::Contains(c.problem));
    REQUIRE_FALSE(error.fix().empty());
  }
  const Error missing = ReadError(Fixture("no_such_file.msh"));
  REQUIRE(missing.where() == Fixture("no_such_file.msh"));
  REQUIRE_THAT(missing.problem(), Catch::Contains("the mesh file does not exist"));
  REQUIRE_THROWS_AS(ReadGmsh(Fixture("two_tets_sparse_v22.msh"), 0.0), Error);
}

// A second-order mesh is refused at its first 10-node tetrahedron block, with
// the element type named and the re-meshing command given.
TEST_CASE("gmsh_reader: unsupported element type is named", "[io][unit]") {
  const std::string path = Fixture("box_with_hole_order2.msh");
  const int line = LineOfFirstBlockOfType(path, "11");
  REQUIRE(line > 0);
  const Error error = ReadError(path);
  REQUIRE(error.where() == path + ":" + std::to_string(line));
  REQUIRE_THAT(error.problem(), Catch::Contains("element type 11") &&
                                    Catch::Contains("10-node second-order tetrahedron"));
  REQUIRE_THAT(error.fix(), Catch::Contains("gmsh -3 -order 1"));
}

}  // namespace dg::io
