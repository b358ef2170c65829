#include "io/gmsh_mesher.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <gmsh.h>

#include "io/gmsh_reader.h"
#include "sim/error.h"

namespace dg::io {
namespace {

using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

double Volume(const sim::TetMesh& mesh) {
  double six_volume = 0;
  for (int e = 0; e < mesh.num_tets(); ++e) six_volume += sim::SixSignedVolume(mesh, e);
  return six_volume / 6.0;
}

double MinSixVolume(const sim::TetMesh& mesh) {
  double least = HUGE_VAL;
  for (int e = 0; e < mesh.num_tets(); ++e) least = std::min(least, sim::SixSignedVolume(mesh, e));
  return least;
}

Eigen::Vector3d Corner(const sim::TetMesh& mesh, const Eigen::Matrix3Xi& faces, int f, int c) {
  return mesh.X_m.col(faces(c, f));
}

std::string TempPath(const std::string& name) {
  return (std::filesystem::path(DG_BINARY_DIR) / name).string();
}

// What Gmsh itself reads back from a .msh file: node and tetrahedron counts and
// the node count of each named physical group.
struct GmshView {
  std::size_t nodes = 0, tets = 0;
  std::map<std::string, std::size_t> group_nodes;
};

GmshView OpenWithGmsh(const std::string& path) {
  struct Session {  // finalizes even when a check throws, so later tests start clean
    Session() { gmsh::initialize(0, nullptr, false); }
    ~Session() { gmsh::finalize(); }
  } session;
  gmsh::option::setNumber("General.Terminal", 0);
  gmsh::open(path);
  GmshView view;
  // Gmsh 4.8 takes a non-empty output vector as preallocated: each call gets fresh ones.
  {
    std::vector<std::size_t> tags;
    std::vector<double> coords, parametric;
    gmsh::model::mesh::getNodes(tags, coords, parametric);
    view.nodes = tags.size();
  }
  {
    std::vector<std::size_t> tags, nodes;
    gmsh::model::mesh::getElementsByType(4, tags, nodes);
    view.tets = tags.size();
  }
  gmsh::vectorpair groups;
  gmsh::model::getPhysicalGroups(groups);
  for (const auto& [dim, tag] : groups) {
    std::string name;
    gmsh::model::getPhysicalName(dim, tag, name);
    std::vector<std::size_t> tags;
    std::vector<double> coords;
    gmsh::model::mesh::getNodesForPhysicalGroup(dim, tag, tags, coords);
    view.group_nodes[name] = tags.size();
  }
  return view;
}

}  // namespace

// The count follows the target: the characteristic length is corrected from the counts obtained.
TEST_CASE("gmsh_mesher: box tetrahedron count within 15% of two targets", "[io][unit]") {
  for (int target : {2000, 8000}) {
    BoxSpec spec;
    spec.target_tets = target;
    MeshReport report;
    const sim::TetMesh mesh = MeshBox(spec, &report);
    INFO("target " << target << ", got " << mesh.num_tets() << " in " << report.passes << " passes");
    REQUIRE(std::abs(mesh.num_tets() - target) <= kTetCountTolerance * target);
  }
}

// A box is meshed exactly: its faces are planes, so the tetrahedra fill it with no
// discretisation error, and each face's node set lies on its plane.
TEST_CASE("gmsh_mesher: box volume, surface, faces and orientation are exact", "[io][unit]") {
  BoxSpec spec;
  spec.size_m = {0.04, 0.05, 0.03};  // unequal sides catch a mixed-up axis
  spec.target_tets = 5000;
  MeshReport report;
  const sim::TetMesh mesh = MeshBox(spec, &report);
  const Eigen::Vector3d s = spec.size_m;

  REQUIRE_THAT(Volume(mesh), WithinRel(s.prod(), 1e-12));
  REQUIRE_THAT(report.volume_m3, WithinRel(s.prod(), 1e-12));
  REQUIRE(MinSixVolume(mesh) > 0);

  const Eigen::Matrix3Xi faces = sim::BoundaryFaces(mesh);
  double area = 0;
  for (int f = 0; f < faces.cols(); ++f) {
    const Eigen::Vector3d a = Corner(mesh, faces, f, 0);
    area += 0.5 * (Corner(mesh, faces, f, 1) - a).cross(Corner(mesh, faces, f, 2) - a).norm();
  }
  REQUIRE_THAT(area, WithinRel(2 * (s.x() * s.y() + s.y() * s.z() + s.z() * s.x()), 1e-12));

  const Eigen::Matrix<double, 3, 2> box = sim::BoundingBox(mesh);
  REQUIRE(box.col(0) == Eigen::Vector3d::Zero());
  REQUIRE(box.col(1) == s);
  for (int a : mesh.node_sets.at("zmin")) REQUIRE(mesh.X_m(2, a) == 0.0);
  for (int a : mesh.node_sets.at("xmax")) REQUIRE(mesh.X_m(0, a) == s.x());
  // Each face's set is exactly the nodes a geometric selection finds on its plane.
  const double tolerance = 1e-9 * s.maxCoeff();
  for (int axis = 0; axis < 3; ++axis) {
    const std::string name(1, "xyz"[axis]);
    const Eigen::Vector3d normal = Eigen::Vector3d::Unit(axis);
    REQUIRE(mesh.node_sets.at(name + "min") ==
            sim::NodesNearPlane(mesh, Eigen::Vector3d::Zero(), normal, tolerance));
    REQUIRE(mesh.node_sets.at(name + "max") == sim::NodesNearPlane(mesh, s, normal, tolerance));
  }
  REQUIRE(mesh.node_sets.at("body").size() == static_cast<std::size_t>(mesh.num_nodes()));
  REQUIRE(mesh.element_sets.at("body").size() == static_cast<std::size_t>(mesh.num_tets()));
  REQUIRE(mesh.element_sets.size() == 1);
  REQUIRE(report.min_radius_ratio > 0.1);
}

// An ellipsoid's mesh is a polyhedron inscribed in it (its boundary nodes lie on
// the surface), so its volume falls short of 4/3 pi abc by the caps its boundary
// triangles cut off. A triangle of circumradius rho cuts a cap no deeper than
// R - sqrt(R^2 - rho^2), R the smallest radius of curvature (c^2/a for semi-axes
// a >= b >= c), so the sum over triangles of area x depth bounds the shortfall
// (2.3% here, the smallest R taken everywhere). With a typical radius of curvature
// (about 20 mm on these axes) the shortfall is about h^2 / (4 R^2), 0.9% for
// h = 3.7 mm at 5000 tets: the 2% check leaves a factor of two.
TEST_CASE("gmsh_mesher: ellipsoid volume within the inscribed polyhedron's bound", "[io][unit]") {
  EllipsoidSpec spec;
  spec.semi_axes_m = {0.03, 0.02, 0.02};
  spec.target_tets = 5000;
  MeshReport report;
  const sim::TetMesh mesh = MeshEllipsoid(spec, &report);
  const Eigen::Vector3d axes = spec.semi_axes_m;
  REQUIRE(std::abs(mesh.num_tets() - spec.target_tets) <= kTetCountTolerance * spec.target_tets);
  REQUIRE(MinSixVolume(mesh) > 0);
  REQUIRE(report.min_radius_ratio > 0.05);  // no boundary slivers

  const std::vector<int>& surface = mesh.node_sets.at("surface");
  REQUIRE(surface == sim::BoundaryNodes(mesh));
  for (int a : surface) {
    REQUIRE_THAT(mesh.X_m.col(a).cwiseQuotient(axes).norm(), WithinAbs(1.0, 1e-9));
  }

  const double r_min = axes.minCoeff() * axes.minCoeff() / axes.maxCoeff();
  const Eigen::Matrix3Xi faces = sim::BoundaryFaces(mesh);
  double cap_bound = 0;
  for (int f = 0; f < faces.cols(); ++f) {
    const Eigen::Vector3d p = Corner(mesh, faces, f, 0);
    const Eigen::Vector3d u = Corner(mesh, faces, f, 1) - p, v = Corner(mesh, faces, f, 2) - p;
    const double area = 0.5 * u.cross(v).norm();
    const double rho = u.norm() * v.norm() * (u - v).norm() / (4 * area);
    cap_bound += area * (r_min - std::sqrt(std::max(0.0, r_min * r_min - rho * rho)));
  }
  const double exact = 4.0 / 3.0 * std::numbers::pi * axes.prod();
  const double shortfall = exact - Volume(mesh);
  INFO("shortfall " << shortfall / exact << ", bound " << cap_bound / exact);
  REQUIRE(shortfall > 0);
  REQUIRE(shortfall <= cap_bound);
  REQUIRE(shortfall <= 0.02 * exact);
}

// Fixed seed, one thread, fixed algorithms: the same spec gives the same mesh bit for bit.
TEST_CASE("gmsh_mesher: same spec gives an identical mesh", "[io][unit]") {
  EllipsoidSpec spec;
  spec.target_tets = 3000;
  const sim::TetMesh first = MeshEllipsoid(spec);
  const sim::TetMesh second = MeshEllipsoid(spec);
  REQUIRE(first.X_m.cols() == second.X_m.cols());
  REQUIRE(first.X_m == second.X_m);
  REQUIRE(first.tets.cols() == second.tets.cols());
  REQUIRE(first.tets == second.tets);
  REQUIRE(first.node_sets == second.node_sets);
  REQUIRE(first.element_sets == second.element_sets);
}

// Gmsh is one per process: meshing from two threads at once is serialised, not corrupted.
TEST_CASE("gmsh_mesher: concurrent calls give the sequential result", "[io][unit]") {
  BoxSpec spec;
  spec.target_tets = 1000;
  const sim::TetMesh expected = MeshBox(spec);
  sim::TetMesh first, second;
  std::thread other([&] { first = MeshBox(spec); });
  second = MeshBox(spec);
  other.join();
  REQUIRE(first.X_m == expected.X_m);
  REQUIRE(second.X_m == expected.X_m);
  REQUIRE(first.tets == expected.tets);
  REQUIRE(second.tets == expected.tets);
}

// Bad specs are refused by name before Gmsh runs.
TEST_CASE("gmsh_mesher: invalid specs are rejected", "[io][unit]") {
  BoxSpec box;
  box.size_m.y() = -0.01;
  REQUIRE_THROWS_AS(MeshBox(box), Error);
  REQUIRE_THROWS_WITH(MeshBox(box), Catch::Contains("size_m"));
  box.size_m.y() = 0.05;
  box.target_tets = 0;
  REQUIRE_THROWS_WITH(MeshBox(box), Catch::Contains("target_tets"));
  EllipsoidSpec ellipsoid;
  ellipsoid.semi_axes_m.z() = std::nan("");
  REQUIRE_THROWS_WITH(MeshEllipsoid(ellipsoid), Catch::Contains("semi_axes_m"));
}

// Gmsh itself reads both written formats back with the same nodes, elements and groups.
TEST_CASE("gmsh_mesher: written .msh files open in Gmsh with their groups", "[io][unit]") {
  BoxSpec spec;
  spec.target_tets = 2000;
  const sim::TetMesh mesh = MeshBox(spec);
  for (int version : {22, 41}) {
    const std::string path = TempPath("gmsh_mesher_box_v" + std::to_string(version) + ".msh");
    WriteMsh(mesh, path, version);
    const GmshView view = OpenWithGmsh(path);
    INFO("version " << version);
    REQUIRE(view.nodes == static_cast<std::size_t>(mesh.num_nodes()));
    REQUIRE(view.tets == static_cast<std::size_t>(mesh.num_tets()));
    REQUIRE(view.group_nodes.size() == mesh.node_sets.size());
    for (const auto& [name, nodes] : mesh.node_sets) REQUIRE(view.group_nodes.at(name) == nodes.size());
  }
}

// The project's reader gets back the mesh that was written: same elements in the same
// order, same sets, coordinates to the 16 significant digits Gmsh writes.
TEST_CASE("gmsh_mesher: written .msh files read back to the same mesh", "[io][unit]") {
  BoxSpec spec;
  spec.size_m = {0.04, 0.05, 0.03};
  spec.target_tets = 2000;
  const sim::TetMesh mesh = MeshBox(spec);
  for (int version : {22, 41}) {
    const std::string path = TempPath("gmsh_mesher_roundtrip_v" + std::to_string(version) + ".msh");
    WriteMsh(mesh, path, version);
    const sim::TetMesh read = ReadGmsh(path);
    INFO("version " << version);
    REQUIRE(read.num_nodes() == mesh.num_nodes());
    REQUIRE((read.X_m - mesh.X_m).cwiseAbs().maxCoeff() <= 1e-15 * spec.size_m.maxCoeff());
    REQUIRE(read.tets == mesh.tets);
    REQUIRE(read.node_sets == mesh.node_sets);
    REQUIRE(read.element_sets == mesh.element_sets);
  }
}

// Writing refuses what a .msh file cannot hold, and reports Gmsh's own failures.
TEST_CASE("gmsh_mesher: WriteMsh errors name the problem", "[io][unit]") {
  BoxSpec spec;
  spec.target_tets = 500;
  sim::TetMesh mesh = MeshBox(spec);
  REQUIRE_THROWS_WITH(WriteMsh(mesh, TempPath("x.msh"), 30), Catch::Contains("version 30"));
  REQUIRE_THROWS_WITH(WriteMsh(mesh, TempPath("x.vtu"), 41), Catch::Contains(".msh"));
  REQUIRE_THROWS_WITH(WriteMsh(mesh, "/nonexistent/folder/x.msh", 41),
                      Catch::Contains("Gmsh") && Catch::Contains("/nonexistent/folder/x.msh"));
  mesh.node_sets["scattered"] = {mesh.node_sets.at("xmin").front(), mesh.node_sets.at("xmax").front()};
  REQUIRE_THROWS_WITH(WriteMsh(mesh, TempPath("x.msh"), 41), Catch::Contains("'scattered'"));
}

}  // namespace dg::io

namespace dg::io {

// The organ-on-a-mount solid: its volume is the analytic cut-ellipsoid volume
// (the flat base exactly, the curved part within the discretisation), its base
// lies on z = 0 and its curved surface on the ellipsoid.
TEST_CASE("gmsh_mesher: truncated ellipsoid stands on z = 0", "[io][unit]") {
  const TruncatedEllipsoidSpec spec;
  const sim::TetMesh mesh = MeshTruncatedEllipsoid(spec);
  REQUIRE(mesh.num_tets() == Approx(spec.target_tets).epsilon(kTetCountTolerance));
  double volume = 0;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const double six = sim::SixSignedVolume(mesh, e);
    REQUIRE(six > 0);
    volume += six / 6;
  }
  // Inscribed in the curved surface: a little short of the analytic volume (see the ellipsoid test).
  REQUIRE(volume < spec.Volume_m3());
  REQUIRE(volume > 0.97 * spec.Volume_m3());
  for (int a : mesh.node_sets.at("base")) REQUIRE(std::abs(mesh.X_m(2, a)) < 1e-12);  // OCC round-off
  const Eigen::Vector3d centre(0, 0, spec.centre_height_m);
  for (int a : mesh.node_sets.at("surface")) {
    const Eigen::Vector3d p = (mesh.X_m.col(a) - centre).cwiseQuotient(spec.semi_axes_m);
    REQUIRE(p.norm() == Approx(1.0).epsilon(1e-6));
  }
  REQUIRE(mesh.X_m.row(2).minCoeff() > -1e-12);
}

}  // namespace dg::io
