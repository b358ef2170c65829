#include "io/gmsh_mesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "io/elapsed_time.h"
#include "io/gmsh_meshing.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

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

gmsh_module::Solid Solid(gmsh_module::Solid::Kind kind, const Eigen::Vector3d& lengths_m) {
  gmsh_module::Solid solid;
  solid.kind = kind;
  solid.lengths_m = {lengths_m.x(), lengths_m.y(), lengths_m.z()};
  return solid;
}

// Meshes `solid` in Gmsh, approaching target_tets.
sim::TetMesh MeshSolid(const std::string& where, gmsh_module::Solid solid, double volume_m3, int target_tets,
                       MeshReport* report) {
  const auto start = std::chrono::steady_clock::now();
  gmsh_module::MeshRequest request;
  request.solid = std::move(solid);
  request.volume_m3 = volume_m3;
  request.target_tets = target_tets;
  request.max_passes = kMaxPasses;
  GmshMeshing meshing =
      MeshInGmsh(request, where, "check the spec; a very large target count may exhaust memory");
  sim::TetMesh& mesh = meshing.mesh;

  MeshReport r;
  r.element_size_m = meshing.element_size_m;
  r.passes = meshing.passes;
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
           where, mesh.num_nodes(), mesh.num_tets(), 1e3 * r.element_size_m, r.passes, meshing.unused_nodes_dropped,
           r.min_radius_ratio, r.mean_radius_ratio, r.wall_ms);
  if (meshing.count_error > kTetCountTolerance) {
    log.warn("{}: got {} tets, more than {:.0f}% off the target; the shape needs a different count",
             where, mesh.num_tets(), 100 * kTetCountTolerance);
  }
  if (r.min_radius_ratio < kPoorRadiusRatio) {
    log.warn("{}: worst element has radius ratio {:.3f}; it will limit the stable time step", where,
             r.min_radius_ratio);
  }
  if (report) *report = r;
  return std::move(mesh);
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
  return MeshSolid(where, Solid(gmsh_module::Solid::Kind::kBox, spec.size_m), spec.size_m.prod(), spec.target_tets,
                   report);
}

sim::TetMesh MeshEllipsoid(const EllipsoidSpec& spec, MeshReport* report) {
  const std::string where =
      fmt::format("Gmsh ellipsoid semi-axes {}, target {} tets", Dims(spec.semi_axes_m), spec.target_tets);
  if (std::string problem = spec.Validate(); !problem.empty()) {
    throw Error("invalid ellipsoid: " + problem, where, "give positive semi-axes (m) and a positive count");
  }
  const Eigen::Vector3d axes = spec.semi_axes_m;
  const double volume_m3 = 4.0 / 3.0 * std::numbers::pi * axes.prod();
  return MeshSolid(where, Solid(gmsh_module::Solid::Kind::kEllipsoid, axes), volume_m3, spec.target_tets, report);
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
  gmsh_module::Solid solid = Solid(gmsh_module::Solid::Kind::kTruncatedEllipsoid, spec.semi_axes_m);
  solid.centre_height_m = spec.centre_height_m;
  return MeshSolid(where, std::move(solid), spec.Volume_m3(), spec.target_tets, report);
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

  gmsh_module::MshFile file;
  file.path = path;
  file.format = version == 22 ? 2.2 : 4.1;
  file.save_all = plain;
  file.coords.resize(3 * static_cast<std::size_t>(mesh.num_nodes()));
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    for (int i = 0; i < 3; ++i) file.coords[3 * a + i] = mesh.X_m(i, a);
  }
  for (const auto& [member, elements] : groups) {
    gmsh_module::MshFile::Volume& volume = file.volumes.emplace_back();
    for (int e : elements) {
      volume.tet_tags.push_back(e + 1);
      for (int c = 0; c < 4; ++c) volume.tet_nodes.push_back(mesh.tets(c, e) + 1);
    }
    for (std::size_t s = 0; s < set_names.size(); ++s) {
      if (member[s]) volume.groups.push_back(set_names[s]);
    }
  }
  std::size_t triangle_tag = num_tets;
  for (const auto& [name, chosen] : surface_faces) {
    gmsh_module::MshFile::Surface& surface = file.surfaces.emplace_back();
    surface.group = name;
    for (int f : chosen) {
      surface.triangle_tags.push_back(++triangle_tag);
      for (int c = 0; c < 3; ++c) surface.triangle_nodes.push_back(faces(c, f) + 1);
    }
  }
  WriteMshInGmsh(file, path + " (from " + mesh.source + ")", "check that the output folder exists and is writable");
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
