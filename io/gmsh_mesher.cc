#include "io/gmsh_mesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <gmsh.h>
#include <spdlog/spdlog.h>

#include "io/elapsed_time.h"
#include "io/gmsh_session.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

// Gmsh's Delaunay mesher with optimisation fills a volume V with about
// 5 V / h^3 tetrahedra at characteristic length h (measured on boxes and
// ellipsoids; regular tetrahedra of edge h would give 8.5). Only the first
// pass relies on it: later passes correct h from the count obtained.
constexpr double kTetsPerCubicLength = 5.0;

// A pass this close to the target ends the search early.
constexpr double kTetCountGoodEnough = 0.05;

// Elements flatter than this make the explicit solver's stable step tiny.
constexpr double kPoorRadiusRatio = 0.05;

std::string Dims(const Eigen::Vector3d& v) {
  return fmt::format("{:g} x {:g} x {:g} m", v.x(), v.y(), v.z());
}

std::string ValidateCommon(const Eigen::Vector3d& lengths_m, const char* name, int target_tets) {
  if (!lengths_m.allFinite() || (lengths_m.array() <= 0).any()) {
    return fmt::format("{} must be positive and finite, got {}", name, Dims(lengths_m));
  }
  if (target_tets <= 0) return fmt::format("target_tets must be positive, got {}", target_tets);
  return "";
}

double TotalVolume(const sim::TetMesh& mesh) {
  double six_volume = 0;
  for (int e = 0; e < mesh.num_tets(); ++e) six_volume += sim::SixSignedVolume(mesh, e);
  return six_volume / 6.0;
}

// Meshes the solid that `build` adds to an empty model (with its physical
// groups, synchronised), approaching target_tets, and converts it.
sim::TetMesh MeshSolid(const std::string& where, double volume_m3, int target_tets,
                       const std::function<void()>& build, MeshReport* report) {
  const auto start = std::chrono::steady_clock::now();
  GmshSession gmsh_session(where, "check the spec; a very large target count may exhaust memory");
  gmsh_session.Run("building the geometry", build);

  // Count ~ h^-3, so each pass rescales h by the cube root of the count's error.
  double h = std::cbrt(kTetsPerCubicLength * volume_m3 / target_tets);
  double best_h = h, best_error = HUGE_VAL, meshed_h = 0;
  int passes = 0;
  auto generate = [&](double size) {
    ++passes;
    gmsh_session.Run("meshing", [&] {
      gmsh::model::mesh::clear();
      gmsh::option::setNumber("Mesh.MeshSizeMin", size);
      gmsh::option::setNumber("Mesh.MeshSizeMax", size);
      gmsh::model::mesh::generate(3);
    });
    meshed_h = size;
    std::vector<std::size_t> tags, nodes;
    gmsh_session.Run("counting tetrahedra", [&] { gmsh::model::mesh::getElementsByType(4, tags, nodes); });
    return static_cast<double>(tags.size());
  };
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    const double count = generate(h);
    const double error = std::abs(count / target_tets - 1.0);
    if (error < best_error) best_error = error, best_h = h;
    if (error <= kTetCountGoodEnough || count == 0) break;
    h *= std::cbrt(count / target_tets);
  }
  if (meshed_h != best_h) generate(best_h);

  std::vector<std::size_t> node_tags, tet_tags, tet_nodes;
  std::vector<double> coords, parametric;
  gmsh_session.Run("reading the mesh", [&] {
    gmsh::model::mesh::getNodes(node_tags, coords, parametric, -1, -1, false, false);
    gmsh::model::mesh::getElementsByType(4, tet_tags, tet_nodes);
  });
  sim::TetMesh mesh;
  mesh.source = where;
  // Gmsh's tags are positive but need not be contiguous.
  std::map<std::size_t, int> node_index, tet_index;
  mesh.X_m.resize(3, static_cast<Eigen::Index>(node_tags.size()));
  for (std::size_t i = 0; i < node_tags.size(); ++i) {
    node_index[node_tags[i]] = static_cast<int>(i);
    mesh.X_m.col(i) << coords[3 * i], coords[3 * i + 1], coords[3 * i + 2];
  }
  mesh.tets.resize(4, static_cast<Eigen::Index>(tet_tags.size()));
  for (std::size_t e = 0; e < tet_tags.size(); ++e) {
    tet_index[tet_tags[e]] = static_cast<int>(e);
    for (int c = 0; c < 4; ++c) mesh.tets(c, e) = node_index.at(tet_nodes[4 * e + c]);
  }

  gmsh_session.Run("reading the physical groups", [&] {
    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups);
    for (const auto& [dim, tag] : groups) {
      std::string name;
      gmsh::model::getPhysicalName(dim, tag, name);
      std::vector<std::size_t> tags;
      std::vector<double> unused;
      gmsh::model::mesh::getNodesForPhysicalGroup(dim, tag, tags, unused);
      std::vector<int>& nodes = mesh.node_sets[name];
      for (std::size_t t : tags) nodes.push_back(node_index.at(t));
      std::sort(nodes.begin(), nodes.end());
      nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
      if (dim != 3) continue;
      std::vector<int> entities;
      gmsh::model::getEntitiesForPhysicalGroup(dim, tag, entities);
      std::vector<int>& elements = mesh.element_sets[name];
      for (int entity : entities) {
        std::vector<std::size_t> tags_in_entity, nodes_in_entity;
        gmsh::model::mesh::getElementsByType(4, tags_in_entity, nodes_in_entity, entity);
        for (std::size_t t : tags_in_entity) elements.push_back(tet_index.at(t));
      }
      std::sort(elements.begin(), elements.end());
    }
  });

  const int dropped = sim::RemoveUnusedNodes(&mesh);
  sim::OrientElements(&mesh);

  MeshReport r;
  r.element_size_m = best_h;
  r.passes = passes;
  r.volume_m3 = TotalVolume(mesh);
  r.min_radius_ratio = HUGE_VAL;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const double q = RadiusRatio(mesh, e);
    r.min_radius_ratio = std::min(r.min_radius_ratio, q);
    r.mean_radius_ratio += q / mesh.num_tets();
  }
  r.wall_ms = MsSince(start);

  spdlog::logger& log = Logger("io");
  log.info("meshed {}: {} nodes, {} tets (h = {:.3g} mm, {} passes, {} unused nodes dropped), "
           "radius ratio min {:.3f} mean {:.3f}, {:.0f} ms",
           where, mesh.num_nodes(), mesh.num_tets(), 1e3 * r.element_size_m, r.passes, dropped,
           r.min_radius_ratio, r.mean_radius_ratio, r.wall_ms);
  if (best_error > kTetCountTolerance) {
    log.warn("{}: got {} tets, more than {:.0f}% off the target; the shape needs a different count",
             where, mesh.num_tets(), 100 * kTetCountTolerance);
  }
  if (r.min_radius_ratio < kPoorRadiusRatio) {
    log.warn("{}: worst element has radius ratio {:.3f}; it will limit the stable time step", where,
             r.min_radius_ratio);
  }
  if (report) *report = r;
  return mesh;
}

// Names the box face that an axis-aligned planar surface lies on.
std::string BoxFaceName(int surface_tag, const Eigen::Vector3d& size_m) {
  double x0, y0, z0, x1, y1, z1;
  gmsh::model::getBoundingBox(2, surface_tag, x0, y0, z0, x1, y1, z1);
  const Eigen::Vector3d lo(x0, y0, z0), hi(x1, y1, z1);
  Eigen::Index axis;
  (hi - lo).cwiseQuotient(size_m).minCoeff(&axis);
  const bool at_max = 0.5 * (lo[axis] + hi[axis]) > 0.5 * size_m[axis];
  return std::string(1, "xyz"[axis]) + (at_max ? "max" : "min");
}

void AddPhysicalGroup(int dim, const std::vector<int>& tags, const std::string& name) {
  gmsh::model::setPhysicalName(dim, gmsh::model::addPhysicalGroup(dim, tags), name);
}

}  // namespace

std::string BoxSpec::Validate() const { return ValidateCommon(size_m, "size_m", target_tets); }

std::string EllipsoidSpec::Validate() const {
  return ValidateCommon(semi_axes_m, "semi_axes_m", target_tets);
}

sim::TetMesh MeshBox(const BoxSpec& spec, MeshReport* report) {
  const std::string where = fmt::format("Gmsh box {}, target {} tets", Dims(spec.size_m), spec.target_tets);
  if (std::string problem = spec.Validate(); !problem.empty()) {
    throw Error("invalid box: " + problem, where, "give positive sizes (m) and a positive count");
  }
  const Eigen::Vector3d size = spec.size_m;
  return MeshSolid(where, size.prod(), spec.target_tets, [size] {
    const int volume = gmsh::model::occ::addBox(0, 0, 0, size.x(), size.y(), size.z());
    gmsh::model::occ::synchronize();
    gmsh::vectorpair surfaces;
    gmsh::model::getEntities(surfaces, 2);
    for (const auto& [dim, tag] : surfaces) AddPhysicalGroup(2, {tag}, BoxFaceName(tag, size));
    AddPhysicalGroup(3, {volume}, "body");
  }, report);
}

sim::TetMesh MeshEllipsoid(const EllipsoidSpec& spec, MeshReport* report) {
  const std::string where =
      fmt::format("Gmsh ellipsoid semi-axes {}, target {} tets", Dims(spec.semi_axes_m), spec.target_tets);
  if (std::string problem = spec.Validate(); !problem.empty()) {
    throw Error("invalid ellipsoid: " + problem, where, "give positive semi-axes (m) and a positive count");
  }
  const Eigen::Vector3d axes = spec.semi_axes_m;
  const double volume_m3 = 4.0 / 3.0 * std::numbers::pi * axes.prod();
  return MeshSolid(where, volume_m3, spec.target_tets, [axes] {
    const int volume = gmsh::model::occ::addSphere(0, 0, 0, 1.0);
    gmsh::model::occ::dilate({{3, volume}}, 0, 0, 0, axes.x(), axes.y(), axes.z());
    gmsh::model::occ::synchronize();
    gmsh::vectorpair surfaces;
    gmsh::model::getEntities(surfaces, 2);
    std::vector<int> surface_tags;
    for (const auto& [dim, tag] : surfaces) surface_tags.push_back(tag);
    AddPhysicalGroup(2, surface_tags, "surface");
    AddPhysicalGroup(3, {volume}, "body");
  }, report);
}

std::string TruncatedEllipsoidSpec::Validate() const {
  if (std::string problem = ValidateCommon(semi_axes_m, "semi_axes_m", target_tets); !problem.empty()) {
    return problem;
  }
  if (!(std::abs(centre_height_m) < semi_axes_m.z())) {
    return "centre_height_m must lie within (-c, c) so that the plane z = 0 cuts the ellipsoid";
  }
  return {};
}

double TruncatedEllipsoidSpec::Volume_m3() const {
  // pi a b times the integral of (1 - z^2/c^2) over the kept part, z from -h to c.
  const double a = semi_axes_m.x(), b = semi_axes_m.y(), c = semi_axes_m.z(), h = centre_height_m;
  return std::numbers::pi * a * b * ((c + h) - (c * c * c + h * h * h) / (3 * c * c));
}

sim::TetMesh MeshTruncatedEllipsoid(const TruncatedEllipsoidSpec& spec, MeshReport* report) {
  const std::string where = fmt::format("Gmsh ellipsoid semi-axes {} centred {:.1f} mm above z = 0, target {} tets",
                                        Dims(spec.semi_axes_m), spec.centre_height_m * 1e3, spec.target_tets);
  if (std::string problem = spec.Validate(); !problem.empty()) {
    throw Error("invalid truncated ellipsoid: " + problem, where, "correct the spec");
  }
  const Eigen::Vector3d axes = spec.semi_axes_m;
  const double h = spec.centre_height_m;
  return MeshSolid(where, spec.Volume_m3(), spec.target_tets, [axes, h] {
    const int ellipsoid = gmsh::model::occ::addSphere(0, 0, h, 1.0);
    gmsh::model::occ::dilate({{3, ellipsoid}}, 0, 0, h, axes.x(), axes.y(), axes.z());
    const double reach = 2 * axes.maxCoeff() + std::abs(h);
    const int half_space = gmsh::model::occ::addBox(-reach, -reach, 0, 2 * reach, 2 * reach, 2 * reach);
    gmsh::vectorpair kept;
    std::vector<gmsh::vectorpair> map;
    gmsh::model::occ::intersect({{3, ellipsoid}}, {{3, half_space}}, kept, map);
    gmsh::model::occ::synchronize();
    gmsh::vectorpair surfaces;
    gmsh::model::getBoundary(kept, surfaces, /*combined=*/true, /*oriented=*/false);
    std::vector<int> curved, base;
    for (const auto& [dim, tag] : surfaces) {
      double x0, y0, z0, x1, y1, z1;
      gmsh::model::getBoundingBox(dim, tag, x0, y0, z0, x1, y1, z1);
      (z1 < 1e-3 * reach ? base : curved).push_back(tag);  // OCC pads bounding boxes loosely
    }
    AddPhysicalGroup(2, curved, "surface");
    AddPhysicalGroup(2, base, "base");
    AddPhysicalGroup(3, {kept.at(0).second}, "body");
  }, report);
}

void WriteMsh(const sim::TetMesh& mesh, const std::string& path, int version) {
  if (version != 22 && version != 41) {
    throw Error("unsupported .msh version " + std::to_string(version), path,
                "use 22 (format 2.2) or 41 (format 4.1)");
  }
  if (path.size() < 4 || path.substr(path.size() - 4) != ".msh") {
    // Gmsh picks the format from the extension.
    throw Error("mesh file name does not end in .msh", path, "name the output FILE.msh");
  }
  const int num_tets = mesh.num_tets();

  // Elements are grouped by the element sets that hold them: one discrete
  // volume per group, and each set's physical volume is the union of its groups.
  const std::vector<std::string> set_names = [&] {
    std::vector<std::string> names;
    for (const auto& [name, elements] : mesh.element_sets) names.push_back(name);
    return names;
  }();
  std::vector<std::vector<bool>> membership(num_tets, std::vector<bool>(set_names.size(), false));
  for (std::size_t s = 0; s < set_names.size(); ++s) {
    for (int e : mesh.element_sets.at(set_names[s])) membership[e][s] = true;
  }
  std::map<std::vector<bool>, std::vector<int>> groups;  // membership -> elements
  for (int e = 0; e < num_tets; ++e) groups[membership[e]].push_back(e);
  const bool plain = mesh.element_sets.empty() && mesh.node_sets.empty();
  if (!plain && groups.count(std::vector<bool>(set_names.size(), false))) {
    // With physical groups present, Gmsh writes only elements that are in one.
    throw Error("some elements are in no element set, and a .msh file with physical groups keeps "
                "only elements in a physical group",
                mesh.source, "add an element set holding every element (e.g. \"body\")");
  }

  // Node sets become physical surfaces of boundary triangles.
  const Eigen::Matrix3Xi faces = sim::BoundaryFaces(mesh);
  std::map<std::string, std::vector<int>> surface_faces;
  for (const auto& [name, nodes] : mesh.node_sets) {
    if (auto it = mesh.element_sets.find(name); it != mesh.element_sets.end()) {
      std::vector<int> element_nodes;
      for (int e : it->second) {
        for (int c = 0; c < 4; ++c) element_nodes.push_back(mesh.tets(c, e));
      }
      std::sort(element_nodes.begin(), element_nodes.end());
      element_nodes.erase(std::unique(element_nodes.begin(), element_nodes.end()), element_nodes.end());
      if (element_nodes != nodes) {
        throw Error("node set '" + name + "' differs from the nodes of the element set of that name",
                    mesh.source, "rename one of the two sets");
      }
      continue;
    }
    std::vector<bool> in_set(mesh.num_nodes(), false);
    for (int a : nodes) in_set[a] = true;
    std::vector<int>& chosen = surface_faces[name];
    std::vector<int> covered;
    for (int f = 0; f < faces.cols(); ++f) {
      if (in_set[faces(0, f)] && in_set[faces(1, f)] && in_set[faces(2, f)]) {
        chosen.push_back(f);
        covered.insert(covered.end(), {faces(0, f), faces(1, f), faces(2, f)});
      }
    }
    std::sort(covered.begin(), covered.end());
    covered.erase(std::unique(covered.begin(), covered.end()), covered.end());
    if (covered != nodes) {
      throw Error(fmt::format("node set '{}' is not a patch of the boundary: {} of its {} nodes are "
                              "on none of its boundary triangles, and a .msh file names nodes only "
                              "through elements",
                              name, nodes.size() - covered.size(), nodes.size()),
                  mesh.source, "write only boundary-surface node sets to .msh, or use .vtu");
    }
  }

  GmshSession gmsh_session(path + " (from " + mesh.source + ")",
                           "check that the output folder exists and is writable");
  gmsh_session.Run("writing the mesh", [&] {
    gmsh::model::add("dynaguide");
    // Every node goes to the first volume; Gmsh needs no finer classification to write.
    std::vector<std::size_t> node_tags(mesh.num_nodes());
    std::vector<double> coords(3 * static_cast<std::size_t>(mesh.num_nodes()));
    for (int a = 0; a < mesh.num_nodes(); ++a) {
      node_tags[a] = a + 1;
      for (int i = 0; i < 3; ++i) coords[3 * a + i] = mesh.X_m(i, a);
    }
    std::map<std::string, std::vector<int>> volumes_of_set;
    int volume_tag = 0;
    for (const auto& [member, elements] : groups) {
      gmsh::model::addDiscreteEntity(3, ++volume_tag);
      if (volume_tag == 1) gmsh::model::mesh::addNodes(3, 1, node_tags, coords);
      std::vector<std::size_t> tags, nodes;
      for (int e : elements) {
        tags.push_back(e + 1);
        for (int c = 0; c < 4; ++c) nodes.push_back(mesh.tets(c, e) + 1);
      }
      gmsh::model::mesh::addElementsByType(volume_tag, 4, tags, nodes);
      for (std::size_t s = 0; s < set_names.size(); ++s) {
        if (member[s]) volumes_of_set[set_names[s]].push_back(volume_tag);
      }
    }
    for (const auto& [name, tags] : volumes_of_set) AddPhysicalGroup(3, tags, name);
    int surface_tag = 0;
    std::size_t triangle_tag = num_tets;
    for (const auto& [name, chosen] : surface_faces) {
      gmsh::model::addDiscreteEntity(2, ++surface_tag);
      std::vector<std::size_t> tags, nodes;
      for (int f : chosen) {
        tags.push_back(++triangle_tag);
        for (int c = 0; c < 3; ++c) nodes.push_back(faces(c, f) + 1);
      }
      gmsh::model::mesh::addElementsByType(surface_tag, 2, tags, nodes);
      AddPhysicalGroup(2, {surface_tag}, name);
    }
    gmsh::option::setNumber("Mesh.MshFileVersion", version == 22 ? 2.2 : 4.1);
    gmsh::option::setNumber("Mesh.Binary", 0);
    gmsh::option::setNumber("Mesh.SaveAll", plain ? 1 : 0);
    gmsh::write(path);
  });
}

double RadiusRatio(const sim::TetMesh& mesh, int element) {
  const Eigen::Vector3d x0 = mesh.X_m.col(mesh.tets(0, element));
  const Eigen::Vector3d a = mesh.X_m.col(mesh.tets(1, element)) - x0;
  const Eigen::Vector3d b = mesh.X_m.col(mesh.tets(2, element)) - x0;
  const Eigen::Vector3d c = mesh.X_m.col(mesh.tets(3, element)) - x0;
  const double six_volume = std::abs(a.dot(b.cross(c)));
  if (six_volume == 0) return 0;
  // r_in = 3 V / (total face area); r_circ = |a^2 (b x c) + b^2 (c x a) + c^2 (a x b)| / (12 V).
  const double twice_area = a.cross(b).norm() + b.cross(c).norm() + c.cross(a).norm() +
                            (b - a).cross(c - a).norm();
  const double r_in = six_volume / twice_area;
  const double r_circ =
      (a.squaredNorm() * b.cross(c) + b.squaredNorm() * c.cross(a) + c.squaredNorm() * a.cross(b))
          .norm() /
      (2 * six_volume);
  return 3 * r_in / r_circ;
}

}  // namespace dg::io
